#include "dofcache/core/atomic_file.h"

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>

#include "dofcache/core/error.h"

namespace dofcache {
namespace {

namespace fs = std::filesystem;

constexpr const char* kTemporaryTag = ".tmp-";

// ".<stem>.tmp-": what every temporary file of `target` starts with.
std::string temporary_prefix(const fs::path& target) {
  return "." + target.stem().string() + kTemporaryTag;
}

}  // namespace

std::string temporary_path_for(const std::string& path) {
  static std::atomic<unsigned> counter{0};
  fs::path p(path);
  std::string name = temporary_prefix(p) + std::to_string(::getpid()) + "-" +
                     std::to_string(counter.fetch_add(1)) + p.extension().string();
  return (p.parent_path() / name).string();
}

void commit_temporary(const std::string& tmp_path, const std::string& path) {
  if (std::rename(tmp_path.c_str(), path.c_str()) != 0)
    throw Error("cannot write '" + path + "': " +
                one_line(std::string("cannot rename the temporary file: ") +
                         std::strerror(errno)));
}

void write_bytes_atomically(const std::string& path, std::string_view bytes, FileMode mode) {
  write_atomically(path, [&](const std::string& tmp) {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    out.close();
    if (!out) throw Error("cannot write '" + path + "'");
    if (mode == FileMode::Executable)
      fs::permissions(tmp, fs::perms::owner_exec | fs::perms::group_exec | fs::perms::others_exec,
                      fs::perm_options::add);
  });
}

void discard_temporary(const std::string& tmp_path) noexcept {
  std::error_code ec;
  fs::remove(tmp_path, ec);
}

void remove_stale_temporaries(const std::vector<std::string>& targets) {
  std::map<fs::path, std::set<std::string>> prefixes;  // directory -> ".<stem>.tmp-"
  for (const std::string& t : targets) {
    if (t.empty()) continue;
    fs::path p(t);
    prefixes[p.parent_path()].insert(temporary_prefix(p));
  }
  const std::size_t tag_size = std::strlen(kTemporaryTag);
  for (const auto& [dir, names] : prefixes) {
    std::error_code ec;
    fs::directory_iterator it(dir.empty() ? fs::path(".") : dir, ec);
    if (ec) continue;
    for (const fs::directory_entry& e : it) {
      std::string name = e.path().filename().string();
      std::size_t tmp = name.find(kTemporaryTag);
      if (tmp == std::string::npos || !names.count(name.substr(0, tmp + tag_size))) continue;
      long pid = std::strtol(name.c_str() + tmp + tag_size, nullptr, 10);
      if (pid > 0 && (::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH)) continue;
      fs::remove(e.path(), ec);
    }
  }
}

}  // namespace dofcache
