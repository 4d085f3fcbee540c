#pragma once
// The lens as JSON, {"focal_length", "fstop", "focus_distance"} (metres, f-number, metres), and
// for a shaped aperture "aperture_blades", "aperture_rotation" (degrees), "aperture_roundness"
// and "anamorphic_ratio": the one shape of statistics files, requests, the viewer's API and
// keyframe files.
#include <nlohmann/json.hpp>

#include "dofcache/lens/thin_lens.h"

namespace dofcache::lens {

inline nlohmann::json lens_json(const ThinLens& lens) {
  nlohmann::json j = {{"focal_length", lens.focal_length},
                      {"fstop", lens.fstop},
                      {"focus_distance", lens.focus_distance}};
  const ApertureShape& a = lens.aperture;
  if (!a.round())  // keyframe keys and the request's names (aperture.h)
    j.update({{"aperture_blades", a.blades},
              {"aperture_rotation", a.rotation_deg},
              {"aperture_roundness", a.roundness},
              {"anamorphic_ratio", a.anamorphic_ratio}});
  return j;
}

}  // namespace dofcache::lens
