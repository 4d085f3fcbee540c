#include "dofcache/render/setup.h"

#include <cmath>

#include <glm/geometric.hpp>

#include "dofcache/core/error.h"
#include "dofcache/scene/default_scene.h"
#include "dofcache/scene/gltf_loader.h"

namespace dofcache::render {

scene::Scene load_scene(const std::string& path, int scene_index,
                        const scene::LoadLimits& limits) {
  scene::LoadOptions options;
  options.scene_index = scene_index;
  options.limits = limits;
  if (path.empty())
    return scene::load_gltf_from_memory(scene::default_scene_gltf(), scene::default_scene_name(),
                                        options);
  return scene::load_gltf(path, options);
}

namespace {

// Autofocus: the depth the centre pixel sees, as a camera's centre-point focus would.
double centre_depth(const scene::Scene& scene, const scene::Accel& accel,
                    const scene::Camera& camera) {
  glm::vec3 origin(camera.camera_to_world[3]);
  glm::vec3 forward = -glm::normalize(glm::vec3(camera.camera_to_world[2]));
  scene::Ray ray;
  ray.origin = origin;
  ray.direction = forward;
  ray.cull_back_faces = true;  // what the camera sees (glTF culls single-sided back faces)
  scene::Hit hit = accel.intersect(ray);
  return hit.valid() ? hit.t : glm::dot(scene.bounds.center() - origin, forward);
}

ResolvedLens mount_real_lens(const scene::Scene& scene, const scene::Accel& accel,
                             const scene::Camera& camera, const LensOverrides& overrides,
                             int width, int height) {
  // mount_lens refuses what a real stop does not take (vignetting, colour, tilt, shift).
  const lens::ApertureShape stop = overrides.aperture.over(camera.lens.aperture).shape();
  if (width < 1 || height < 1) throw Error("a real lens needs the image's size");
  ResolvedLens r;
  const auto system = lens::read_lens_file(overrides.real.file);
  const double fstop = overrides.fstop.value_or(0.0);  // 0: the table's stop
  double focus = 0.0;
  if (overrides.focus_distance || camera.lens.focus_distance) {
    focus = overrides.focus_distance.value_or(camera.lens.focus_distance.value_or(0.0));
  } else {
    // Not closer than a few focal lengths beyond the lens (its closest focus is 4 f and more).
    const double f = system->effective_focal_length();
    double length = 0.0;
    for (const lens::LensSurface& s : system->surfaces()) length += s.thickness;
    focus = std::max(centre_depth(scene, accel, camera), 6.0 * std::abs(f) + length);
    r.focus_from_scene = true;
  }
  r.mounted = lens::mount_lens(system, overrides.real.file, fstop, focus, overrides.real.sensor, width,
                               height, overrides.real.exposure_follows_lens, stop);
  r.lens = r.mounted.equivalent();
  return r;
}

}  // namespace

ResolvedLens resolve_lens(const scene::Scene& scene, const scene::Accel& accel,
                          const scene::Camera& camera, const LensOverrides& overrides, int width,
                          int height) {
  if (!overrides.real.file.empty())
    return mount_real_lens(scene, accel, camera, overrides, width, height);
  ResolvedLens r;
  lens::ThinLens& l = r.lens;
  l.focal_length = overrides.focal_length.value_or(camera.lens.focal_length.value_or(0.05));
  l.fstop = overrides.fstop.value_or(camera.lens.fstop.value_or(4.0));
  l.aperture = overrides.aperture.over(camera.lens.aperture).shape();
  if (overrides.focus_distance || camera.lens.focus_distance) {
    l.focus_distance = overrides.focus_distance.value_or(camera.lens.focus_distance.value_or(0.0));
    return r;
  }
  l.focus_distance = std::max(centre_depth(scene, accel, camera), 2.0 * l.focal_length);
  r.focus_from_scene = true;
  return r;
}

int height_for_width(const scene::Camera& camera, int width) {
  double aspect = camera.aspect_ratio.value_or(4.0f / 3.0f);
  if (!(aspect > 0.0)) aspect = 4.0 / 3.0;
  return std::max(1, static_cast<int>(std::lround(width / aspect)));
}

}  // namespace dofcache::render
