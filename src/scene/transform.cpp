#include "dofcache/scene/transform.h"

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>

namespace dofcache::scene {

glm::dmat4 trs_matrix(const glm::dvec3& translation, const glm::dquat& rotation,
                      const glm::dvec3& scale) {
  return glm::translate(glm::dmat4(1.0), translation) * glm::mat4_cast(rotation) *
         glm::scale(glm::dmat4(1.0), scale);
}

const char* rigid_camera_frame(const glm::dmat4& world, glm::dmat4& frame) {
  glm::dvec3 z(world[2]), y(world[1]);
  double zl = glm::length(z);
  if (!(zl > kDegenerateAxisLength)) return "collapses the view direction";
  z /= zl;
  y -= glm::dot(y, z) * z;
  double yl = glm::length(y);
  if (!(yl > kDegenerateAxisLength)) return "collapses the up direction";
  y /= yl;
  frame = glm::dmat4(1.0);
  frame[0] = glm::dvec4(glm::cross(y, z), 0.0);
  frame[1] = glm::dvec4(y, 0.0);
  frame[2] = glm::dvec4(z, 0.0);
  frame[3] = glm::dvec4(glm::dvec3(world[3]), 1.0);
  return nullptr;
}

}  // namespace dofcache::scene
