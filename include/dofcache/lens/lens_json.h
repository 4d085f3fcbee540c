#pragma once
// The lens as JSON, {"focal_length", "fstop", "focus_distance"} (metres, f-number, metres), and
// for a shaped aperture "aperture_blades", "aperture_rotation" (degrees), "aperture_roundness"
// and "anamorphic_ratio", with a vignetting stop "vignetting_stop" ([radius, distance], metres),
// with chromatic aberration "axial_ca" and "lateral_ca", with a transmission profile
// "aperture_profile" and "aperture_profile_strength", and "lens_tilt" and "lens_shift" ([x, y]):
// the one shape of statistics files, requests, the viewer's API and keyframe files.
#include <cmath>
#include <optional>
#include <utility>

#include <nlohmann/json.hpp>

#include "dofcache/lens/thin_lens.h"

namespace dofcache::lens {

inline nlohmann::json lens_json(const ThinLens& lens) {
  nlohmann::json j = {{"focal_length", lens.focal_length},
                      {"fstop", lens.fstop},
                      {"focus_distance", lens.focus_distance}};
  const ApertureShape& a = lens.aperture;
  if (!a.plain())  // keyframe keys and the request's names (aperture.h)
    j.update({{"aperture_blades", a.blades},
              {"aperture_rotation", a.rotation_deg},
              {"aperture_roundness", a.roundness},
              {"anamorphic_ratio", a.anamorphic_ratio}});
  if (a.vignetting()) j["vignetting_stop"] = {a.stop.radius, a.stop.distance};
  if (a.chromatic()) j.update({{"axial_ca", a.axial_ca}, {"lateral_ca", a.lateral_ca}});
  if (a.weighted())
    j.update({{"aperture_profile", aperture_profile_name(a.profile)},
              {"aperture_profile_strength", a.profile_strength}});
  if (a.tilted()) j["lens_tilt"] = {a.tilt_x_deg, a.tilt_y_deg};
  if (a.shifted()) j["lens_shift"] = {a.shift_x, a.shift_y};
  if (!a.image.empty()) j["aperture_image"] = a.image;
  return j;
}

// "vignetting_stop" ([radius, distance] in metres), "lens_tilt" and "lens_shift" ([x, y]) as
// every reader takes them: two finite numbers;
// nullopt for anything else (the reader names the key in its own error). VignettingStop's
// values are judged by ApertureShape::validate.
inline std::optional<std::pair<double, double>> number_pair_from_json(const nlohmann::json& j) {
  if (!j.is_array() || j.size() != 2 || !j[0].is_number() || !j[1].is_number())
    return std::nullopt;
  const double a = j[0].get<double>(), b = j[1].get<double>();
  if (!std::isfinite(a) || !std::isfinite(b)) return std::nullopt;
  return std::pair{a, b};
}

inline std::optional<VignettingStop> vignetting_stop_from_json(const nlohmann::json& j) {
  const auto pair = number_pair_from_json(j);
  if (!pair) return std::nullopt;
  return VignettingStop{pair->first, pair->second};
}

}  // namespace dofcache::lens
