#pragma once
// The lens as JSON, {"focal_length", "fstop", "focus_distance"} (metres, f-number, metres), and
// for a shaped aperture "aperture_blades", "aperture_rotation" (degrees), "aperture_roundness"
// and "anamorphic_ratio", with a vignetting stop "vignetting_stop" ([radius, distance], metres),
// with chromatic aberration "axial_ca" and "lateral_ca", with a transmission profile
// "aperture_profile" and "aperture_profile_strength", and "lens_tilt" and "lens_shift" ([x, y]):
// the one shape of statistics files, requests, the viewer's API and keyframe files.
#include <cmath>
#include <map>
#include <optional>
#include <string>
#include <utility>

#include <glm/trigonometric.hpp>
#include <nlohmann/json.hpp>

#include "dofcache/lens/real_lens.h"
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

// A mounted real lens as statistics and EXR headers record it: the file, the effective focal length
// and f-number, the focus distance from the sensor, the film distance behind the rear element,
// the field of view and the part of the sensor used. Metres and degrees.
inline nlohmann::json real_lens_json(const MountedLens& m) {
  const RealLens& l = *m.lens;
  const glm::dvec2 fov = glm::degrees(m.field_of_view());
  return {{"lens_file", m.source},
          {"effective_focal_length", l.cardinal().focal_length},
          {"fstop", l.fstop()},
          {"focus_distance_from_sensor", l.focused_at_infinity()
                                             ? nlohmann::json("infinity")
                                             : nlohmann::json(l.focus_distance())},
          {"film_distance", l.film_distance()},
          {"field_of_view", {fov.x, fov.y}},
          {"film_size", {m.film_size.x, m.film_size.y}}};
}

// The same as EXR header strings ("dofcache:real_lens.<key>").
inline std::map<std::string, std::string> real_lens_attributes(const MountedLens& m) {
  std::map<std::string, std::string> a;
  const nlohmann::json j = real_lens_json(m);  // items() of a temporary would dangle
  for (const auto& [key, value] : j.items())
    a["real_lens." + key] = value.is_string() ? value.get<std::string>() : value.dump();
  return a;
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
