#include "dofcache/core/file.h"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <iterator>

#include "dofcache/core/error.h"

namespace dofcache {

std::string read_file(const std::string& path, const std::string& what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot open " + what + " (" + std::strerror(errno) + ")");
  std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw Error(path + ": read error");
  return data;
}

}  // namespace dofcache
