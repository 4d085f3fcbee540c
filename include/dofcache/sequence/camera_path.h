#pragma once
// Camera paths: how the camera (pose and lens) moves over time, and the frames sampled from it.
//
// Two sources (docs/sequence.md):
//   * a glTF animation whose channels target the camera's node or any of its ancestors
//     (translation, rotation, scale; STEP, LINEAR, CUBICSPLINE), composed down the node
//     hierarchy exactly as the glTF node transforms are;
//   * a JSON keyframe file: per key a time, and any of position, look-at target or rotation,
//     vertical field of view and lens values (focal length, f-number, focus distance), so focus
//     pulls and aperture changes animate too.
// Either becomes a CameraPath: a chain of animated node transforms plus optional look-at and lens
// tracks, evaluated at any time.
#include <optional>
#include <string>
#include <vector>

#include <glm/gtc/quaternion.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include "dofcache/lens/thin_lens.h"
#include "dofcache/render/setup.h"
#include "dofcache/scene/accel.h"
#include "dofcache/scene/scene.h"
#include "dofcache/sequence/track.h"

namespace dofcache::sequence {

// One node of a glTF hierarchy: local = T * R * S (tracks override the rest values), or a fixed
// matrix (which glTF forbids animating).
struct AnimatedNode {
  std::optional<glm::dmat4> matrix;
  glm::dvec3 translation{0.0};
  glm::dquat rotation{1.0, 0.0, 0.0, 0.0};
  glm::dvec3 scale{1.0};
  Track<glm::dvec3> translation_track, scale_track;
  Track<glm::dquat> rotation_track;

  glm::dmat4 local(double time) const;
  bool animated() const {
    return !translation_track.empty() || !rotation_track.empty() || !scale_track.empty();
  }
};

// The camera at one instant.
struct PathSample {
  glm::dmat4 camera_to_world{1.0};  // rigid: orthonormal axes, the camera looks down -Z, +Y up
  // Animated values; unset where the path does not animate them.
  std::optional<double> yfov, focal_length, fstop, focus_distance;
  lens::ApertureChoices aperture;
};

struct CameraPath {
  std::string source;  // where it came from, for messages
  // Root first; the camera's world matrix is the product of their local matrices.
  std::vector<AnimatedNode> chain;
  // Look-at orientation (keyframe files with "target"): when set, the camera at the chain's
  // position looks at target(t), with `up` as the up direction.
  Track<glm::dvec3> target;
  glm::dvec3 up{0.0, 1.0, 0.0};
  Track<double> yfov, focal_length, fstop, focus_distance;  // empty: not animated
  // The aperture's shape (lens/aperture.h); blades hold from key to key (step).
  Track<double> aperture_blades, aperture_rotation, aperture_roundness, anamorphic_ratio;
  Track<double> vignetting_radius, vignetting_distance;  // keyed together: "vignetting_stop"
  Track<double> axial_ca, lateral_ca;
  // The profile's index (lens::ApertureProfile), held from key to key, and its strength.
  Track<double> aperture_profile, aperture_profile_strength;
  Track<double> lens_tilt_x, lens_tilt_y, lens_shift_x, lens_shift_y;  // keyed as pairs
  std::optional<double> fps;  // the frame rate the file suggests (keyframe files)
  double start_time = 0.0, end_time = 0.0;  // seconds: first and last key of any track

  // Throws dofcache::Error if the pose is degenerate at `time` (a collapsed axis, a target at
  // the camera position, `up` along the view direction).
  PathSample at(double time) const;
};

// The animation of `gltf_file` that moves `camera` (a camera loaded from that file:
// Camera::node is its node). `animation` selects one by name or index; empty: the first animation
// with a channel on the camera node or one of its ancestors. Channels on other nodes are ignored
// (the scene is static). Throws dofcache::Error naming the file and the element for a missing
// animation, bad accessors, non-increasing times and the like.
CameraPath load_gltf_camera_path(const std::string& gltf_file, const scene::Camera& camera,
                                 const std::string& animation = "");

// A JSON keyframe file (format in docs/sequence.md). Values the file does not animate stay those
// of `base` (its pose) or of the lens resolution (lens values). Throws dofcache::Error naming the
// file and the key on any problem.
CameraPath load_keyframe_path(const std::string& json_file, const scene::Camera& base);
// The same from JSON text; `name` is used in messages.
CameraPath parse_keyframe_path(const std::string& json_text, const std::string& name,
                               const scene::Camera& base);

// Appends the camera's pose, field of view and `lens` as a new last key of the keyframe file
// `json_file` (e.g. from `dofcache view`), one second after its last key: in frames at the file's
// fps if its keys give frames, else in seconds. The orientation is written as the file's keys give
// theirs: a rotation quaternion, or for a file of "target" keys a target on the optical axis at
// the focus distance. A missing file is created (format version 1, 24 fps, smooth interpolation,
// `description`). The file is checked as load_keyframe_path checks it before and after, and
// rewritten atomically. Returns the number of keys now in the file. Throws dofcache::Error (one
// line) if the file exists but is not a valid keyframe file, or cannot be written.
int append_keyframe(const std::string& json_file, const scene::Camera& camera,
                    const lens::ThinLens& lens, const std::string& description = "");

// One frame of a sequence: its number, the camera and the resolved lens.
struct FrameSpec {
  int number = 0;
  double time = 0.0;  // seconds
  scene::Camera camera;
  lens::ThinLens lens;     // with a real lens, its thin-lens equivalent at this frame's focus
  lens::MountedLens real_lens;  // a real lens (overrides.real), focused for this frame
  bool autofocus = false;  // focus found by probing the scene (no value anywhere)
};

// Frames [first, last] of `path` sampled at `fps` (frame f at time f / fps). Lens precedence, per
// value: the path's animated value, then `overrides` (command line), then the camera's
// extras.lens, then render::resolve_lens's defaults (autofocus on the image centre). Throws
// dofcache::Error on a bad range or fps, or a lens value that fails ThinLens::validate. A real
// lens (overrides.real) is mounted per frame for width x height images, focused at the frame's
// focus distance (from the sensor): its field of view breathes as the focus moves, as a real
// lens's does; the path's focal lengths and fields of view do not apply to it.
std::vector<FrameSpec> plan_frames(const scene::Scene& scene, const scene::Accel& accel,
                                   const scene::Camera& base, const CameraPath& path, double fps,
                                   int first, int last, const render::LensOverrides& overrides,
                                   int width = 0, int height = 0);

// Every `step`-th frame of `frames` from the first, plus the last (keyframes, e.g. to warm a
// cache over a path); step 1 keeps all. Throws dofcache::Error if step < 1.
std::vector<FrameSpec> keep_every(std::vector<FrameSpec> frames, int step);

// The frames a path covers at `fps`: ceil(start * fps) .. floor(end * fps).
std::pair<int, int> path_frame_range(const CameraPath& path, double fps);

}  // namespace dofcache::sequence
