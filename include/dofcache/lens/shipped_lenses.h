#pragma once
// The prescriptions shipped in scenes/lenses/, built into the program: `--lens-file
// double_gauss_50mm` (the name, without a directory) finds one where no such file exists, and the
// viewer lists them (docs/lens.md).
#include <string>
#include <string_view>
#include <vector>

namespace dofcache::lens {

struct ShippedLens {
  std::string_view name;   // the file's name without ".lens"
  std::string_view table;  // the file's text
};

// In name order.
const std::vector<ShippedLens>& shipped_lenses();

// Their names, comma-separated (help texts and errors).
std::string shipped_lens_names();

// The shipped lens `name` names (with or without ".lens"; a path with a directory names none),
// or nullptr.
const ShippedLens* find_shipped_lens(std::string_view name);

}  // namespace dofcache::lens
