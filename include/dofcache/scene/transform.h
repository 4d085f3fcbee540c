#pragma once
// glTF node transforms and the camera frame, defined once for the scene loader and the camera
// paths of sequences (which animate the same nodes), so a camera at rest and on its path agree.
#include <optional>

#include <glm/gtc/quaternion.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

namespace dofcache::scene {

// T * R * S, as glTF composes a node's translation, rotation and scale (glTF 2.0, 3.5.3).
glm::dmat4 trs_matrix(const glm::dvec3& translation, const glm::dquat& rotation,
                      const glm::dvec3& scale);

// A node's local transform as the file gives it: a matrix, or translation, rotation (unit) and
// scale (absent parts at their identity values). gltf::Document::node_transform validates it.
struct NodeTransform {
  std::optional<glm::dmat4> matrix;
  glm::dvec3 translation{0.0};
  glm::dquat rotation{1.0, 0.0, 0.0, 0.0};
  glm::dvec3 scale{1.0};

  glm::dmat4 local() const {
    return matrix ? *matrix : trs_matrix(translation, rotation, scale);
  }
};

// Axes shorter than this count as collapsed (a camera frame cannot be built from them).
constexpr double kDegenerateAxisLength = 1e-12;

// The rigid part of a camera node's world matrix: glTF cameras ignore scale, so the view axis (Z)
// and the up direction (Y) are kept and an orthonormal right-handed frame is rebuilt from them.
// Returns nullptr and sets `frame`, or what is wrong ("collapses the view direction", "collapses
// the up direction") for the caller's message.
const char* rigid_camera_frame(const glm::dmat4& world, glm::dmat4& frame);

}  // namespace dofcache::scene
