#pragma once
// Embree 3 BVH over Scene::mesh. Queries are thread-safe.
// Both queries skip what glTF says is not there: alphaMode MASK cut-outs (alpha < cutoff) and,
// with probability 1 - alpha, BLEND surfaces (Embree filter functions on a geometry of their
// own), so shadows are cut out too; intersect() also skips the back faces of single-sided
// materials when Ray::cull_back_faces.
#include <cstdint>
#include <limits>
#include <memory>

#include <glm/vec3.hpp>

#include "dofcache/scene/scene.h"

namespace dofcache::scene {

struct Ray {
  glm::vec3 origin{0.0f};
  glm::vec3 direction{0.0f, 0.0f, -1.0f};  // need not be unit; t is in units of |direction|
  float tnear = 0.0f;
  float tfar = std::numeric_limits<float>::infinity();
  // Mixed into the per-hit random number of BLEND materials (stochastic transparency): rays of
  // different samples should carry different seeds; the same ray and seed give the same answer.
  std::uint32_t seed = 0;
  // glTF culls the back faces of single-sided materials: camera rays set this (render/camera.cpp).
  // Rays of light transport (bounces, shadows) see both sides, so that single-sided geometry
  // neither leaks light nor lets light and BSDF sampling disagree about what blocks a path. The
  // layered preview's clipped renders clear it to see into objects the near plane cuts open.
  bool cull_back_faces = false;
};

struct Hit {
  static constexpr std::uint32_t kNone = 0xffffffffu;
  float t = std::numeric_limits<float>::infinity();
  std::uint32_t triangle = kNone;
  float u = 0.0f, v = 0.0f;  // Embree barycentrics: p = (1-u-v) p0 + u p1 + v p2
  bool valid() const { return triangle != kNone; }
};

class Accel {
 public:
  explicit Accel(const Scene& scene);  // builds the BVH; throws dofcache::Error on Embree errors
  ~Accel();
  Accel(const Accel&) = delete;
  Accel& operator=(const Accel&) = delete;

  Hit intersect(const Ray& ray) const;
  // True if anything blocks the segment origin + t*direction, t in (tnear, tfar).
  bool occluded(const Ray& ray) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dofcache::scene
