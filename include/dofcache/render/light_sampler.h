#pragma once
// Which emissive triangle a light sample goes to.
//
// Power alone is a poor guide when lights lie at very different distances: in a room lit by a
// ceiling panel, a small glowing object is chosen in proportion to its tiny power even by the
// surfaces right next to it, which it lights far more than the panel does, and each of those rare
// choices is a firefly that a thousand samples per pixel do not average away. So a sample first
// chooses a light (the emissive triangles of one object) in proportion to its power over the
// squared distance to the shading point, the distance bounded below by the light's radius, and
// never a light that cannot reach the point (wholly below its horizon, or a one-sided flat light
// seen from behind); then a triangle of that light in proportion to power. This is the importance
// pbrt-v4 gives a light cluster, without its light BVH: scenes carry few emissive objects, and more
// than kMaxLights are merged into spatial clusters. With a single light it is exactly
// Scene::sample_emitter.
#include <cstddef>
#include <cstdint>
#include <glm/vec3.hpp>
#include <vector>

#include "dofcache/scene/scene.h"

namespace dofcache::render {

class LightSampler {
 public:
  static constexpr int kMaxLights = 64;

  explicit LightSampler(const scene::Scene& scene);

  // Lights the emitters are grouped into (0 without emitters).
  std::size_t light_count() const { return lights_.size(); }

  // Picks an emitter (index into scene.emitters) for the surface point x with unit normal n, from u
  // in [0, 1), and the probability of that pick. False, with nothing picked, when no emitter can
  // light x.
  bool sample(glm::vec3 x, glm::vec3 n, float u, std::size_t* emitter, float* probability) const;
  // The probability with which sample(x, n, .) picks `emitter`.
  float probability(glm::vec3 x, glm::vec3 n, std::size_t emitter) const;
  // A lower bound on the distance from x to the nearest emissive triangle (0 within a light's
  // bounding sphere; +inf without emitters): how far direct light may be assumed smooth.
  float nearest_light_distance(glm::vec3 x) const;

 private:
  struct Light {
    glm::vec3 center{0.0f};
    float radius = 0.0f;           // bounding sphere of its triangles
    float power = 0.0f;            // sum of area * luminance
    bool one_sided_plane = false;  // all its triangles one-sided, in one plane facing `normal`
    glm::vec3 normal{0.0f};
    float offset = 0.0f;               // that plane: dot(normal, y) = offset
    std::uint32_t begin = 0, end = 0;  // its emitters: order_[begin, end)
  };
  // Unnormalised weight of every light for (x, n) into w[0 .. light_count()); returns their sum.
  float weights(glm::vec3 x, glm::vec3 n, float* w) const;

  const scene::Scene& scene_;
  std::vector<Light> lights_;
  std::vector<std::uint32_t> order_;  // emitter indices, grouped by light
  std::vector<float> cdf_;            // per entry of order_: cumulative power within its light
  std::vector<std::uint32_t> light_of_,
      slot_of_;  // per emitter: its light, its entry in order_
};

}  // namespace dofcache::render
