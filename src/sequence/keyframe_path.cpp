// JSON keyframe files (docs/sequence.md, "Keyframe files"): read, and appended to. Each quantity (position, target or
// rotation, yfov, focal length, f-number, focus distance) is its own track, made of the keys
// that give it, so a focus pull needs nothing but focus distances.
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <tuple>
#include <type_traits>

#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>
#include <nlohmann/json.hpp>

#include "dofcache/core/atomic_file.h"
#include "dofcache/core/error.h"
#include "dofcache/core/file.h"
#include "dofcache/lens/lens_json.h"
#include "dofcache/sequence/camera_path.h"

namespace dofcache::sequence {
namespace {

using nlohmann::json;

constexpr int kFormatVersion = 1;
constexpr const char* kFormatKey = "dofcache_camera_path";

enum class KeyInterpolation { Step, Linear, Smooth };

class KeyframeParser {
 public:
  explicit KeyframeParser(std::string name) : name_(std::move(name)) {}

  CameraPath parse(const std::string& text, const scene::Camera& base) {
    json doc;
    try {
      doc = json::parse(text);
    } catch (const json::exception& e) {  // parse_error, and out_of_range for 1e400
      std::string what = e.what();
      std::size_t at = what.find("] ");
      fail("invalid JSON: " + (at == std::string::npos ? what : what.substr(at + 2)));
    }
    if (!doc.is_object()) fail("the file must hold a JSON object");
    for (const auto& item : doc.items()) {
      const std::string& key = item.key();  // a plain name: C++17 lambdas cannot capture bindings
      static const char* known[] = {kFormatKey, "fps", "interpolation", "up", "keys",
                                    "description", "scene"};
      if (std::find_if(std::begin(known), std::end(known),
                       [&](const char* k) { return key == k; }) == std::end(known))
        fail("unknown member '" + key + "' (valid: " + kFormatKey +
             ", fps, interpolation, up, keys, description, scene)");
    }
    if (!doc.contains(kFormatKey) || !doc[kFormatKey].is_number_integer())
      fail(std::string("missing \"") + kFormatKey + "\": " + std::to_string(kFormatVersion) +
           " (the format version)");
    if (doc[kFormatKey].get<long long>() != kFormatVersion)
      fail("format version " + doc[kFormatKey].dump() + " is not supported (this is version " +
           std::to_string(kFormatVersion) + ")");

    CameraPath path;
    path.source = name_;
    if (doc.contains("fps")) {
      double fps = number(doc["fps"], "fps");
      if (!(fps > 0.0)) fail("fps must be positive");
      path.fps = fps;
    }
    KeyInterpolation mode = KeyInterpolation::Linear;
    if (doc.contains("interpolation")) {
      if (!doc["interpolation"].is_string()) fail("interpolation must be a string");
      std::string s = doc["interpolation"].get<std::string>();
      for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      if (s == "step") mode = KeyInterpolation::Step;
      else if (s == "linear") mode = KeyInterpolation::Linear;
      else if (s == "smooth") mode = KeyInterpolation::Smooth;
      else fail("unknown interpolation '" + doc["interpolation"].get<std::string>() +
                "' (valid: step, linear, smooth)");
    }
    if (doc.contains("up")) path.up = vec3(doc["up"], "up");
    if (!(glm::length(path.up) > 0.0)) fail("up must not be zero");
    if (!doc.contains("keys") || !doc["keys"].is_array() || doc["keys"].empty())
      fail("\"keys\" must be a non-empty array of keyframes");

    // The camera itself: one node at the base camera's pose, its tracks from the keys.
    AnimatedNode node;
    glm::dmat4 base_m(base.camera_to_world);
    node.translation = glm::dvec3(base_m[3]);
    node.rotation = glm::normalize(glm::quat_cast(glm::dmat3(base_m)));
    Track<glm::dvec3> position, target;
    Track<glm::dquat> rotation;
    Track<double> yfov, focal_length, fstop, focus;
    Track<double> blades, rotation_deg, roundness, ratio, stop_radius, stop_distance, axial,
        lateral, profile, strength, tilt_x, tilt_y, shift_x, shift_y;
    const double fps_for_frames = path.fps.value_or(24.0);
    double last_time = -INFINITY;
    const json& keys = doc["keys"];
    for (std::size_t k = 0; k < keys.size(); ++k) {
      const json& key = keys[k];
      key_ = "key " + std::to_string(k);
      if (!key.is_object()) fail("must be an object");
      for (const auto& item : key.items()) {
        const std::string& member = item.key();
        static const char* known[] = {"frame",          "time",          "position",
                                      "target",         "rotation",      "yfov",
                                      "focal_length",   "fstop",         "focus_distance",
                                      "aperture_blades", "aperture_rotation",
                                      "aperture_roundness", "anamorphic_ratio",
                                      "vignetting_stop", "axial_ca", "lateral_ca",
                                      "aperture_profile", "aperture_profile_strength",
                                      "lens_tilt", "lens_shift"};
        if (std::find_if(std::begin(known), std::end(known),
                         [&](const char* m) { return member == m; }) == std::end(known))
          fail("unknown member '" + member +
               "' (valid: frame or time, position, target or rotation, yfov, focal_length, fstop, "
               "focus_distance, aperture_blades, aperture_rotation, aperture_roundness, "
               "anamorphic_ratio, vignetting_stop, axial_ca, lateral_ca, aperture_profile, "
               "aperture_profile_strength, lens_tilt, lens_shift)");
      }
      if (key.contains("frame") == key.contains("time"))
        fail("give exactly one of \"frame\" (a frame number) or \"time\" (seconds)");
      double t = key.contains("time") ? number(key["time"], "time")
                                      : number(key["frame"], "frame") / fps_for_frames;
      if (!(t > last_time)) fail("keys must be in strictly increasing time");
      last_time = t;
      if (key.contains("position")) add(position, t, vec3(key["position"], "position"));
      if (key.contains("target")) add(target, t, vec3(key["target"], "target"));
      if (key.contains("rotation")) add(rotation, t, quat(key["rotation"]));
      if (key.contains("yfov")) add(yfov, t, positive(key["yfov"], "yfov"));
      if (key.contains("focal_length"))
        add(focal_length, t, positive(key["focal_length"], "focal_length"));
      if (key.contains("fstop")) add(fstop, t, positive(key["fstop"], "fstop"));
      if (key.contains("focus_distance"))
        add(focus, t, positive(key["focus_distance"], "focus_distance"));
      // The aperture's shape, each value checked as the lens checks it.
      lens::ApertureChoices a;
      if (key.contains("aperture_blades")) {
        const double b = number(key["aperture_blades"], "aperture_blades");
        a.blades = lens::blade_count(b);
        if (!a.blades) fail("aperture_blades must be a whole number");
        add(blades, t, b);
      }
      if (key.contains("aperture_rotation"))
        add(rotation_deg, t, *(a.rotation_deg = number(key["aperture_rotation"], "aperture_rotation")));
      if (key.contains("aperture_roundness"))
        add(roundness, t, *(a.roundness = number(key["aperture_roundness"], "aperture_roundness")));
      if (key.contains("anamorphic_ratio"))
        add(ratio, t, *(a.anamorphic_ratio = number(key["anamorphic_ratio"], "anamorphic_ratio")));
      if (key.contains("vignetting_stop")) {
        a.vignetting_stop = lens::vignetting_stop_from_json(key["vignetting_stop"]);
        if (!a.vignetting_stop) fail("vignetting_stop must be [radius, distance] in metres");
        add(stop_radius, t, a.vignetting_stop->radius);
        add(stop_distance, t, a.vignetting_stop->distance);
      }
      if (key.contains("axial_ca")) add(axial, t, *(a.axial_ca = number(key["axial_ca"], "axial_ca")));
      if (key.contains("lateral_ca"))
        add(lateral, t, *(a.lateral_ca = number(key["lateral_ca"], "lateral_ca")));
      if (key.contains("aperture_profile")) {
        if (!key["aperture_profile"].is_string()) fail("aperture_profile must be a name");
        try {
          a.profile = lens::parse_aperture_profile(key["aperture_profile"].get<std::string>());
        } catch (const Error& e) {
          fail(e.what());
        }
        add(profile, t, static_cast<double>(*a.profile));
      }
      for (auto [name, field, tx, ty] :
           {std::tuple{"lens_tilt", &a.lens_tilt, &tilt_x, &tilt_y},
            std::tuple{"lens_shift", &a.lens_shift, &shift_x, &shift_y}}) {
        if (!key.contains(name)) continue;
        *field = lens::number_pair_from_json(key[name]);
        if (!*field) fail(std::string(name) + " must be [x, y]");
        add(*tx, t, (*field)->first);
        add(*ty, t, (*field)->second);
      }
      if (key.contains("aperture_profile_strength"))
        add(strength, t,
            *(a.profile_strength =
                  number(key["aperture_profile_strength"], "aperture_profile_strength")));
      try {
        a.shape().validate();
      } catch (const Error& e) {
        fail(e.what());
      }
    }
    key_.clear();
    if (!target.empty() && !rotation.empty())
      fail("keys give both \"target\" and \"rotation\"; use one way to orient the camera");

    bool any = false;
    finish(position, mode, "position", any);
    finish(target, mode, "target", any);
    finish(rotation, mode, "rotation", any);
    finish(yfov, mode, "yfov", any);
    finish(focal_length, mode, "focal_length", any);
    finish(fstop, mode, "fstop", any);
    finish(focus, mode, "focus_distance", any);
    finish(blades, KeyInterpolation::Step, "aperture_blades", any);
    finish(rotation_deg, mode, "aperture_rotation", any);
    finish(roundness, mode, "aperture_roundness", any);
    finish(ratio, mode, "anamorphic_ratio", any);
    finish(stop_radius, mode, "vignetting_stop", any);
    finish(stop_distance, mode, "vignetting_stop", any);
    finish(axial, mode, "axial_ca", any);
    finish(lateral, mode, "lateral_ca", any);
    finish(profile, KeyInterpolation::Step, "aperture_profile", any);
    finish(strength, mode, "aperture_profile_strength", any);
    finish(tilt_x, mode, "lens_tilt", any);
    finish(tilt_y, mode, "lens_tilt", any);
    finish(shift_x, mode, "lens_shift", any);
    finish(shift_y, mode, "lens_shift", any);
    if (!any) fail("no key animates anything (give position, target, rotation or lens values)");
    node.translation_track = std::move(position);
    node.rotation_track = std::move(rotation);
    path.chain.push_back(std::move(node));
    path.target = std::move(target);
    path.yfov = std::move(yfov);
    path.focal_length = std::move(focal_length);
    path.fstop = std::move(fstop);
    path.focus_distance = std::move(focus);
    path.aperture_blades = std::move(blades);
    path.aperture_rotation = std::move(rotation_deg);
    path.aperture_roundness = std::move(roundness);
    path.anamorphic_ratio = std::move(ratio);
    path.vignetting_radius = std::move(stop_radius);
    path.vignetting_distance = std::move(stop_distance);
    path.axial_ca = std::move(axial);
    path.lateral_ca = std::move(lateral);
    path.aperture_profile = std::move(profile);
    path.aperture_profile_strength = std::move(strength);
    path.lens_tilt_x = std::move(tilt_x);
    path.lens_tilt_y = std::move(tilt_y);
    path.lens_shift_x = std::move(shift_x);
    path.lens_shift_y = std::move(shift_y);
    path.start_time = keys_start_;
    path.end_time = keys_end_;
    return path;
  }

 private:
  [[noreturn]] void fail(const std::string& problem) const {
    // one_line: a problem may quote the file's text (a member name may hold an escaped newline).
    throw Error(one_line(name_ + ": " + (key_.empty() ? "" : key_ + ": ") + problem));
  }

  double number(const json& v, const char* what) const {
    if (!v.is_number()) fail(std::string(what) + " must be a number");
    double d = v.get<double>();
    if (!std::isfinite(d)) fail(std::string(what) + " must be finite");
    return d;
  }
  double positive(const json& v, const char* what) const {
    double d = number(v, what);
    if (!(d > 0.0)) fail(std::string(what) + " must be positive");
    return d;
  }
  glm::dvec3 vec3(const json& v, const char* what) const {
    if (!v.is_array() || v.size() != 3) fail(std::string(what) + " must be an array of 3 numbers");
    return {number(v[0], what), number(v[1], what), number(v[2], what)};
  }
  glm::dquat quat(const json& v) const {
    if (!v.is_array() || v.size() != 4)
      fail("rotation must be a quaternion [x, y, z, w] (glTF order)");
    glm::dquat q(number(v[3], "rotation"), number(v[0], "rotation"), number(v[1], "rotation"),
                 number(v[2], "rotation"));
    double len = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
    if (!(std::abs(len - 1.0) < 1e-3)) fail("rotation must be a unit quaternion");
    return q * (1.0 / len);
  }

  template <class T>
  void add(Track<T>& track, double t, const T& value) {
    track.times.push_back(t);
    track.values.push_back(value);
    keys_start_ = std::min(keys_start_, t);
    keys_end_ = std::max(keys_end_, t);
  }

  // Sets the interpolation; "smooth" becomes a glTF CUBICSPLINE through the keys with
  // Catmull-Rom tangents inside and zero tangents at the first and last key (ease in and out).
  template <class T>
  void finish(Track<T>& track, KeyInterpolation mode, const char* what, bool& any) const {
    if (track.empty()) return;
    any = true;
    if constexpr (std::is_same_v<T, glm::dquat>) {
      for (std::size_t k = 1; k < track.values.size(); ++k)  // one hemisphere: no long way round
        if (glm::dot(track.values[k - 1], track.values[k]) < 0.0)
          track.values[k] = -track.values[k];
    }
    if (mode == KeyInterpolation::Step) track.interpolation = Interpolation::Step;
    if (mode == KeyInterpolation::Linear) track.interpolation = Interpolation::Linear;
    if (mode == KeyInterpolation::Smooth) {
      std::vector<T> v = track.values, out;
      const std::vector<double>& t = track.times;
      const std::size_t n = v.size();
      for (std::size_t k = 0; k < n; ++k) {
        T m = v[k] * 0.0;
        if (k > 0 && k + 1 < n) m = (v[k + 1] - v[k - 1]) * (1.0 / (t[k + 1] - t[k - 1]));
        out.push_back(m);
        out.push_back(v[k]);
        out.push_back(m);
      }
      track.values = std::move(out);
      track.interpolation = Interpolation::CubicSpline;
    }
    track.validate(name_ + ": " + what);
  }

  std::string name_;
  std::string key_;
  double keys_start_ = INFINITY, keys_end_ = -INFINITY;
};

}  // namespace

CameraPath parse_keyframe_path(const std::string& json_text, const std::string& name,
                               const scene::Camera& base) {
  return KeyframeParser(name).parse(json_text, base);
}

CameraPath load_keyframe_path(const std::string& json_file, const scene::Camera& base) {
  return parse_keyframe_path(read_file(json_file), json_file, base);
}

int append_keyframe(const std::string& json_file, const scene::Camera& camera,
                    const lens::ThinLens& lens, const std::string& description) {
  lens.validate();
  json doc;
  std::error_code ec;
  if (std::filesystem::exists(json_file, ec)) {
    load_keyframe_path(json_file, camera);  // a valid keyframe file, or its one-line error
    std::ifstream in(json_file, std::ios::binary);
    doc = json::parse(in);
  } else {
    doc = {{kFormatKey, kFormatVersion}, {"fps", 24}, {"interpolation", "smooth"},
           {"keys", json::array()}};
    if (!description.empty()) doc["description"] = description;
  }
  json& keys = doc["keys"];
  json key = json::object();
  if (keys.empty() || keys.back().contains("frame")) {
    const double fps = doc.contains("fps") ? doc["fps"].get<double>() : 24.0;
    const double last = keys.empty() ? -fps : keys.back()["frame"].get<double>();
    key["frame"] = static_cast<long long>(std::floor(last + fps + 0.5));  // one second on
  } else {
    key["time"] = keys.back()["time"].get<double>() + 1.0;
  }
  const glm::dmat4 m(camera.camera_to_world);
  const glm::dvec3 position(m[3]);
  key["position"] = {position.x, position.y, position.z};
  const bool by_target = std::any_of(keys.begin(), keys.end(),
                                     [](const json& k) { return k.contains("target"); });
  if (by_target) {
    const glm::dvec3 target = position - glm::normalize(glm::dvec3(m[2])) * lens.focus_distance;
    key["target"] = {target.x, target.y, target.z};
  } else {
    const glm::dquat q = glm::normalize(glm::quat_cast(glm::dmat3(m)));
    key["rotation"] = {q.x, q.y, q.z, q.w};  // glTF order
  }
  key["yfov"] = camera.yfov;
  key.update(lens::lens_json(lens));
  keys.push_back(std::move(key));

  const std::string text = doc.dump(2) + "\n";
  parse_keyframe_path(text, json_file, camera);  // what is written reads back
  write_bytes_atomically(json_file, text);
  return static_cast<int>(keys.size());
}

}  // namespace dofcache::sequence
