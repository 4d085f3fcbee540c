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
  glm::vec3 right{1.0f, 0.0f, 0.0f}, up{0.0f, 1.0f, 0.0f};  // the image's +x and +y
  // Camera-space depth of a world point, as render::ThinLensCamera::depth.
  float depth(glm::vec3 world) const { return glm::dot(world - position, forward); }
  // How much of its circle of confusion a world point's bokeh keeps in its narrowest direction
  // (lens::ThinLens::stop_reach), as render::ThinLensCamera::footprint_reach.
  double footprint_reach(glm::vec3 world) const {
    if (!imaging.lens.aperture.stopped()) return 1.0;
    const glm::vec3 v = world - position;
    const float z = glm::dot(v, forward);
    if (!(z > 0.0f)) return 1.0;
    return imaging.lens.stop_reach({glm::dot(v, right) / z, glm::dot(v, up) / z}, z);
  }
};

}  // namespace dofcache::cache
