#pragma once
// Turning user choices into render inputs: which scene, which camera, which lens. Shared by the
// command-line tool, the benchmarks and the sequence renderer so the rules live in one place.
#include <optional>
#include <string>

#include "dofcache/lens/real_lens.h"
#include "dofcache/lens/thin_lens.h"
#include "dofcache/scene/accel.h"
#include "dofcache/scene/gltf_loader.h"
#include "dofcache/scene/scene.h"

namespace dofcache::render {

// Loads `path` (.gltf/.glb), or the built-in default scene if `path` is empty, within `limits`.
scene::Scene load_scene(const std::string& path, int scene_index = -1,
                        const scene::LoadLimits& limits = {});

// Lens values given on the command line; each overrides the camera's `extras.lens`.
struct LensOverrides {
  std::optional<double> focal_length, fstop, focus_distance;
  lens::ApertureChoices aperture;
  // A real lens (lens/real_lens.h). With a file, the focus distance is measured from the sensor,
  // the focal length comes from the lens, and only `fstop` given here sets its stop (a scene's
  // extras.lens f-number is its thin lens's).
  lens::RealLensChoices real;
};

// Where each lens value came from, for messages.
struct ResolvedLens {
  lens::ThinLens lens;            // with a real lens, its thin-lens equivalent
  lens::MountedLens mounted;      // the real lens, or none
  bool focus_from_scene = false;  // focus found by probing the scene (no value given anywhere)
};

// Precedence: override, then the camera's extras.lens, then a fallback: 50 mm at f/4 focused on
// whatever the centre of the image sees (or the scene's bounding-box centre if nothing is hit).
// A real lens is mounted for an image of width x height pixels (its film is the part of the
// sensor such an image covers); throws dofcache::Error (an unreadable table, an f-number wider
// than the lens's, a focus it cannot reach, an aperture shape, which a real lens's round stop
// does not take yet).
ResolvedLens resolve_lens(const scene::Scene& scene, const scene::Accel& accel,
                          const scene::Camera& camera, const LensOverrides& overrides,
                          int width = 0, int height = 0);

// Image height for `width` from the camera's aspect ratio (4:3 if it has none).
int height_for_width(const scene::Camera& camera, int width);

}  // namespace dofcache::render
