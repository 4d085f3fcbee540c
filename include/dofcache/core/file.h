#pragma once
// Reading a whole file: the one reader of scene, path, request, cache and journal files.
#include <string>

namespace dofcache {

// The bytes of `path`. Throws dofcache::Error "<path>: cannot open <what> (<reason>)" if it
// cannot be opened, "<path>: read error" if reading fails.
std::string read_file(const std::string& path, const std::string& what = "file");

}  // namespace dofcache
