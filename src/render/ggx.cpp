#include "dofcache/render/ggx.h"

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>

namespace dofcache::render {

namespace {
constexpr float kPi = 3.14159265358979323846f;
}

float ggx_d(float n_h, float alpha) {
  const float a2 = alpha * alpha;
  const float d = n_h * n_h * (a2 - 1.0f) + 1.0f;
  return a2 / (kPi * d * d);
}

float smith_g1(float n_x, float alpha) {
  const float a2 = alpha * alpha;
  return 2.0f * n_x / (n_x + std::sqrt(a2 + (1.0f - a2) * n_x * n_x));
}

glm::vec3 sample_ggx_visible_normal(glm::vec3 v, float alpha, glm::vec2 u) {
  // The view direction stretched to the unit-roughness configuration, where the visible normals
  // project to a disc: a point of the disc, its lower half squeezed onto the part of the
  // hemisphere seen from v, lifted to the hemisphere and unstretched.
  const glm::vec3 vh = glm::normalize(glm::vec3(alpha * v.x, alpha * v.y, v.z));
  const float lensq = vh.x * vh.x + vh.y * vh.y;
  const glm::vec3 t1 =
      lensq > 0.0f ? glm::vec3(-vh.y, vh.x, 0.0f) / std::sqrt(lensq) : glm::vec3(1.0f, 0.0f, 0.0f);
  const glm::vec3 t2 = glm::cross(vh, t1);
  const float r = std::sqrt(u.x), phi = 2.0f * kPi * u.y;
  const float a = r * std::cos(phi);
  const float s = 0.5f * (1.0f + vh.z);
  const float b = (1.0f - s) * std::sqrt(std::max(0.0f, 1.0f - a * a)) + s * r * std::sin(phi);
  const glm::vec3 nh = a * t1 + b * t2 + std::sqrt(std::max(0.0f, 1.0f - a * a - b * b)) * vh;
  return glm::normalize(glm::vec3(alpha * nh.x, alpha * nh.y, std::max(nh.z, 1e-6f)));
}

float ggx_vndf_pdf(float n_h, float n_v, float alpha) {
  return ggx_d(n_h, alpha) * smith_g1(n_v, alpha) / (4.0f * n_v);
}

}  // namespace dofcache::render
