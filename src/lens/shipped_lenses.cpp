#include "dofcache/lens/shipped_lenses.h"

namespace dofcache::lens {

std::string shipped_lens_names() {
  std::string names;
  for (const ShippedLens& l : shipped_lenses()) names += (names.empty() ? "" : ", ") + std::string(l.name);
  return names;
}

const ShippedLens* find_shipped_lens(std::string_view name) {
  if (name.find('/') != std::string_view::npos) return nullptr;
  if (name.size() > 5 && name.substr(name.size() - 5) == ".lens") name.remove_suffix(5);
  for (const ShippedLens& lens : shipped_lenses())
    if (lens.name == name) return &lens;
  return nullptr;
}

}  // namespace dofcache::lens
