#pragma once
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "dofcache/lens/thin_lens.h"

namespace dofcache::cache {

// What the reuse rule needs of a frame's camera: its imaging (lens, field of view, resolution)
// and where it looks from (render::ThinLensCamera::frame_camera gives it).
struct FrameCamera {
  lens::LensImaging imaging;
  glm::vec3 position{0.0f}, forward{0.0f, 0.0f, -1.0f};  // forward: unit length
  // Camera-space depth of a world point, as render::ThinLensCamera::depth.
  float depth(glm::vec3 world) const { return glm::dot(world - position, forward); }
};

}  // namespace dofcache::cache
