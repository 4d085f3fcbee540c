#include "dofcache/view/browser.h"

#include <spawn.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <vector>

extern char** environ;

namespace dofcache::view {

std::string browser_command() {
  if (const char* b = std::getenv("BROWSER"); b && *b) return b;
  const char* path = std::getenv("PATH");
  if (!path) return "";
  for (const char* name : {"xdg-open", "open"}) {
    std::string dirs = path;
    std::size_t start = 0;
    while (start <= dirs.size()) {
      std::size_t end = dirs.find(':', start);
      if (end == std::string::npos) end = dirs.size();
      std::filesystem::path candidate = std::filesystem::path(dirs.substr(start, end - start)) / name;
      if (access(candidate.c_str(), X_OK) == 0) return candidate.string();
      start = end + 1;
    }
  }
  return "";
}

bool open_in_browser(const std::string& url) {
  const std::string program = browser_command();
  if (program.empty()) return false;
  std::vector<char*> argv = {const_cast<char*>(program.c_str()), const_cast<char*>(url.c_str()),
                             nullptr};
  pid_t pid = 0;
  return posix_spawnp(&pid, program.c_str(), nullptr, nullptr, argv.data(), environ) == 0;
}

}  // namespace dofcache::view
