#pragma once
// One exception type for everything a user can cause (bad files, bad options). The CLI turns it into
// a single "dofcache: error: ..." line and a non-zero exit; the core asserts its own invariants.
#include <stdexcept>
#include <string>

namespace dofcache {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
};

}  // namespace dofcache
