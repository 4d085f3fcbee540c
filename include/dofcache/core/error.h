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

// Folds a multi-line message (as libraries such as tinygltf and OpenImageIO write them) into one
// line, lines joined by "; ", so every error the user sees is a single line.
inline std::string one_line(const std::string& text) {
  std::string out;
  for (char c : text) {
    if (c == '\n' || c == '\r') {
      if (!out.empty() && out.back() != ' ') out += "; ";
    } else {
      out += c;
    }
  }
  while (!out.empty() && (out.back() == ' ' || out.back() == ';')) out.pop_back();
  return out;
}

}  // namespace dofcache
