#include "dofcache/sequence/camera_path.h"

#include <cmath>

#include <glm/geometric.hpp>

#include "dofcache/core/error.h"
#include "dofcache/scene/transform.h"

namespace dofcache::sequence {
namespace {

std::string seconds(double t) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g s", t);
  return buf;
}

}  // namespace

glm::dmat4 AnimatedNode::local(double time) const {
  if (matrix) return *matrix;
  glm::dvec3 t = translation_track.empty() ? translation : translation_track.at(time);
  glm::dquat r = rotation_track.empty() ? rotation : rotation_track.at(time);
  glm::dvec3 s = scale_track.empty() ? scale : scale_track.at(time);
  return scene::trs_matrix(t, r, s);
}

PathSample CameraPath::at(double time) const {
  glm::dmat4 world(1.0);
  for (const AnimatedNode& node : chain) world = world * node.local(time);
  const std::string where = source + " at " + seconds(time);
  PathSample s;
  if (!target.empty()) {
    // Look-at: the camera looks down -Z, so +Z points from the target back to the camera.
    glm::dvec3 eye(world[3]);
    glm::dvec3 z = eye - target.at(time);
    double zl = glm::length(z);
    if (!(zl > 1e-9)) throw Error(where + ": the target is at the camera position");
    z /= zl;
    glm::dvec3 x = glm::cross(up, z);
    double xl = glm::length(x);
    if (!(xl > 1e-9)) throw Error(where + ": the view direction is parallel to 'up'");
    x /= xl;
    s.camera_to_world = glm::dmat4(1.0);
    s.camera_to_world[0] = glm::dvec4(x, 0.0);
    s.camera_to_world[1] = glm::dvec4(glm::cross(z, x), 0.0);
    s.camera_to_world[2] = glm::dvec4(z, 0.0);
    s.camera_to_world[3] = glm::dvec4(eye, 1.0);
  } else {
    // The loader's camera frame (transform.h), so a path at rest gives the scene's camera.
    if (const char* problem = scene::rigid_camera_frame(world, s.camera_to_world))
      throw Error(where + ": the camera transform " + problem);
  }
  if (!yfov.empty()) s.yfov = yfov.at(time);
  if (!focal_length.empty()) s.focal_length = focal_length.at(time);
  if (!fstop.empty()) s.fstop = fstop.at(time);
  if (!focus_distance.empty()) s.focus_distance = focus_distance.at(time);
  if (!aperture_blades.empty())
    s.aperture.blades = static_cast<int>(std::lround(aperture_blades.at(time)));
  if (!aperture_rotation.empty()) s.aperture.rotation_deg = aperture_rotation.at(time);
  if (!aperture_roundness.empty()) s.aperture.roundness = aperture_roundness.at(time);
  if (!anamorphic_ratio.empty()) s.aperture.anamorphic_ratio = anamorphic_ratio.at(time);
  if (!vignetting_radius.empty())
    s.aperture.vignetting_stop =
        lens::VignettingStop{vignetting_radius.at(time), vignetting_distance.at(time)};
  if (!axial_ca.empty()) s.aperture.axial_ca = axial_ca.at(time);
  if (!lateral_ca.empty()) s.aperture.lateral_ca = lateral_ca.at(time);
  if (!aperture_profile.empty())
    s.aperture.profile =
        static_cast<lens::ApertureProfile>(std::lround(aperture_profile.at(time)));
  if (!aperture_profile_strength.empty())
    s.aperture.profile_strength = aperture_profile_strength.at(time);
  if (!lens_tilt_x.empty()) s.aperture.lens_tilt = std::pair{lens_tilt_x.at(time), lens_tilt_y.at(time)};
  if (!lens_shift_x.empty())
    s.aperture.lens_shift = std::pair{lens_shift_x.at(time), lens_shift_y.at(time)};
  return s;
}

std::pair<int, int> path_frame_range(const CameraPath& path, double fps) {
  if (!(fps > 0.0) || !std::isfinite(fps)) throw Error("frame rate must be a positive number");
  // A hair of tolerance so that keys at exact frame times (in floating point) count.
  const double first = std::max(std::ceil(path.start_time * fps - 1e-6), 0.0);
  const double last = std::max(std::floor(path.end_time * fps + 1e-6), first);
  // Checked before the conversion: a frame number beyond int is undefined behaviour (found by
  // fuzzing). The same bound as a --frames range's nine digits.
  constexpr double kLastFrame = 999999999.0;
  if (!(last <= kLastFrame))
    throw Error(path.source + ": the path's last key is at frame " +
                std::to_string(path.end_time * fps).substr(0, 16) + " at " +
                std::to_string(fps).substr(0, 8) + " fps, beyond frame 999999999, the last a "
                "sequence numbers");
  return {static_cast<int>(first), static_cast<int>(last)};
}

std::vector<FrameSpec> plan_frames(const scene::Scene& scene, const scene::Accel& accel,
                                   const scene::Camera& base, const CameraPath& path, double fps,
                                   int first, int last, const render::LensOverrides& overrides,
                                   int width, int height) {
  if (!(fps > 0.0) || !std::isfinite(fps)) throw Error("frame rate must be a positive number");
  if (first < 0 || last < first)
    throw Error("frame range " + std::to_string(first) + "-" + std::to_string(last) +
                " is empty or negative");
  std::vector<FrameSpec> frames;
  frames.reserve(static_cast<std::size_t>(last - first) + 1);
  for (int f = first; f <= last; ++f) {
    FrameSpec spec;
    spec.number = f;
    spec.time = f / fps;
    PathSample s = path.at(spec.time);
    spec.camera = base;
    spec.camera.camera_to_world = glm::mat4(s.camera_to_world);
    if (s.yfov) {
      if (!(*s.yfov > 0.0 && *s.yfov < 3.14159))
        throw Error(path.source + ": yfov " + std::to_string(*s.yfov) + " at frame " +
                    std::to_string(f) + " is not in (0, pi)");
      spec.camera.yfov = static_cast<float>(*s.yfov);
    }
    // Animated values win over the command line, which wins over the scene's extras.lens.
    render::LensOverrides o = overrides;
    if (s.focal_length) o.focal_length = s.focal_length;
    if (s.fstop) o.fstop = s.fstop;
    if (s.focus_distance) o.focus_distance = s.focus_distance;
    o.aperture = s.aperture.over(o.aperture);
    try {
      render::ResolvedLens lens = render::resolve_lens(scene, accel, spec.camera, o, width, height);
      spec.lens = lens.lens;
      spec.real_lens = lens.mounted;
      spec.autofocus = lens.focus_from_scene;
      spec.lens.validate();
    } catch (const Error& e) {
      throw Error(path.source + ": frame " + std::to_string(f) + ": " + e.what());
    }
    frames.push_back(std::move(spec));
  }
  return frames;
}

std::vector<FrameSpec> keep_every(std::vector<FrameSpec> frames, int step) {
  if (step < 1) throw Error("frame step must be >= 1, got " + std::to_string(step));
  std::vector<FrameSpec> kept;
  for (std::size_t i = 0; i < frames.size(); ++i)
    if (i % static_cast<std::size_t>(step) == 0 || i + 1 == frames.size())
      kept.push_back(std::move(frames[i]));
  return kept;
}

}  // namespace dofcache::sequence
