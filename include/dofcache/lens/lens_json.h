#pragma once
// The lens as JSON, {"focal_length", "fstop", "focus_distance"} (metres, f-number, metres): the
// one shape of statistics files, requests, the viewer's API and keyframe files.
#include <nlohmann/json.hpp>

#include "dofcache/lens/thin_lens.h"

namespace dofcache::lens {

inline nlohmann::json lens_json(const ThinLens& lens) {
  return {{"focal_length", lens.focal_length},
          {"fstop", lens.fstop},
          {"focus_distance", lens.focus_distance}};
}

}  // namespace dofcache::lens
