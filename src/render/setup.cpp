#include "dofcache/render/setup.h"

#include <cmath>

#include <glm/geometric.hpp>

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

ResolvedLens resolve_lens(const scene::Scene& scene, const scene::Accel& accel,
                          const scene::Camera& camera, const LensOverrides& overrides) {
  ResolvedLens r;
  lens::ThinLens& l = r.lens;
  l.focal_length = overrides.focal_length.value_or(camera.lens.focal_length.value_or(0.05));
  l.fstop = overrides.fstop.value_or(camera.lens.fstop.value_or(4.0));
  l.aperture = overrides.aperture.over(camera.lens.aperture).shape();
  if (overrides.focus_distance || camera.lens.focus_distance) {
    l.focus_distance = overrides.focus_distance.value_or(camera.lens.focus_distance.value_or(0.0));
    return r;
  }
  // Autofocus: the depth the centre pixel sees, as a camera's centre-point focus would.
  glm::vec3 origin(camera.camera_to_world[3]);
  glm::vec3 forward = -glm::normalize(glm::vec3(camera.camera_to_world[2]));
  scene::Ray ray;
  ray.origin = origin;
  ray.direction = forward;
  ray.cull_back_faces = true;  // what the camera sees (glTF culls single-sided back faces)
  scene::Hit hit = accel.intersect(ray);
  double depth = hit.valid() ? hit.t : glm::dot(scene.bounds.center() - origin, forward);
  l.focus_distance = std::max(depth, 2.0 * l.focal_length);
  r.focus_from_scene = true;
  return r;
}

int height_for_width(const scene::Camera& camera, int width) {
  double aspect = camera.aspect_ratio.value_or(4.0f / 3.0f);
  if (!(aspect > 0.0)) aspect = 4.0 / 3.0;
  return std::max(1, static_cast<int>(std::lround(width / aspect)));
}

}  // namespace dofcache::render
