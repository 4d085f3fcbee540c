// Triangle light sampling: the solid angle against hand-computed values, Arvo's warp against the
// triangle it must cover uniformly, and the densities the two strategies report.
#include "dofcache/render/triangle_sampling.h"

#include <gtest/gtest.h>

#include <cmath>

#include <glm/geometric.hpp>

#include "dofcache/core/rng.h"

namespace dofcache::render {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Moller-Trumbore: does the ray from x along d meet the triangle, and where.
bool hits(glm::vec3 x, glm::vec3 d, const Triangle& t, float* distance) {
  const glm::vec3 e1 = t.b - t.a, e2 = t.c - t.a, h = glm::cross(d, e2);
  const float a = glm::dot(e1, h);
  if (std::abs(a) < 1e-12f) return false;
  const glm::vec3 s = x - t.a;
  const float u = glm::dot(s, h) / a;
  const glm::vec3 q = glm::cross(s, e1);
  const float v = glm::dot(d, q) / a;
  const float tol = 1e-4f;
  if (u < -tol || v < -tol || u + v > 1.0f + tol) return false;
  *distance = glm::dot(e2, q) / a;
  return *distance > 0.0f;
}

TEST(TriangleSampling, SolidAngleOfAnOctantIsPiOverTwo) {
  // The triangle (1,0,0), (0,1,0), (0,0,1) seen from the origin covers one eighth of the sphere.
  const Triangle octant{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  EXPECT_NEAR(solid_angle(glm::vec3(0.0f), octant), kPi / 2.0, 1e-6);
  // Scaling it and moving the eye with it changes nothing; either winding gives the same.
  const Triangle far{{3, 1, 1}, {1, 3, 1}, {1, 1, 3}};
  EXPECT_NEAR(solid_angle(glm::vec3(1.0f), far), kPi / 2.0, 1e-6);
  const Triangle reversed{octant.a, octant.c, octant.b};
  EXPECT_NEAR(solid_angle(glm::vec3(0.0f), reversed), kPi / 2.0, 1e-6);
}

TEST(TriangleSampling, SmallDistantTriangleSubtendsAreaOverDistanceSquared) {
  // A right triangle of legs 0.01 (area 5e-5) facing the point from 2 m: Omega ~ A / d^2.
  const Triangle t{{0, 0, 2}, {0.01f, 0, 2}, {0, 0.01f, 2}};
  EXPECT_NEAR(solid_angle(glm::vec3(0.0f), t), 5e-5 / 4.0, 1e-8);
  // Seen edge-on (the point in its plane) it subtends nothing.
  EXPECT_EQ(solid_angle(glm::vec3(1.0f, 1.0f, 2.0f), t), 0.0f);
}

// A triangle 2 cm from the point: solid-angle sampling applies.
const Triangle kNear{{-0.05f, -0.02f, 0.02f}, {0.3f, -0.02f, 0.02f}, {-0.05f, 0.3f, 0.02f}};

TEST(TriangleSampling, SphericalWarpCoversTheTriangleUniformly) {
  const glm::vec3 x(0.0f);
  const float omega = solid_angle(x, kNear);
  ASSERT_GT(omega, kMinSolidAngle);
  ASSERT_LT(omega, kMaxSolidAngle);
  // Four sub-triangles through the edge midpoints; each must get its share of solid angle.
  const glm::vec3 ab = 0.5f * (kNear.a + kNear.b), bc = 0.5f * (kNear.b + kNear.c),
                  ca = 0.5f * (kNear.c + kNear.a);
  const Triangle parts[4] = {{kNear.a, ab, ca}, {ab, kNear.b, bc}, {ca, bc, kNear.c}, {ab, bc, ca}};
  int counts[4] = {0, 0, 0, 0};
  const int n = 40000;
  Rng rng(3, 5);
  for (int k = 0; k < n; ++k) {
    const glm::vec3 w = sample_spherical_triangle(x, kNear, {rng.uniform(), rng.uniform()});
    ASSERT_NEAR(glm::length(w), 1.0f, 1e-4f);
    float d;
    ASSERT_TRUE(hits(x, w, kNear, &d)) << "sample " << k << " misses the triangle";
    for (int i = 0; i < 4; ++i)
      if (hits(x, w, parts[i], &d)) {
        ++counts[i];
        break;
      }
  }
  for (int i = 0; i < 4; ++i) {
    const double share = solid_angle(x, parts[i]) / omega;
    const double sigma = std::sqrt(share * (1.0 - share) / n);
    EXPECT_NEAR(counts[i] / double(n), share, 4.0 * sigma) << "part " << i;
  }
}

// Both strategies: the reported density is the one triangle_pdf gives, and the estimate of the
// solid angle, the mean of 1 / pdf, is unbiased.
void check_strategy(glm::vec3 x, const Triangle& t) {
  const double omega = solid_angle(x, t);
  const int n = 20000;
  double sum = 0.0;
  Rng rng(7, 11);
  for (int k = 0; k < n; ++k) {
    TriangleSample s;
    ASSERT_TRUE(sample_triangle(x, t, {rng.uniform(), rng.uniform()}, &s));
    float d;
    ASSERT_TRUE(hits(x, s.wi, t, &d));
    EXPECT_NEAR(d, s.distance, 1e-3f * s.distance);
    EXPECT_NEAR(triangle_pdf(x, t, s.wi, s.distance), s.pdf, 1e-3f * s.pdf);
    sum += 1.0 / s.pdf;
  }
  EXPECT_NEAR(sum / n / omega, 1.0, 0.02);
}

TEST(TriangleSampling, SolidAngleStrategyNearTheLight) { check_strategy(glm::vec3(0.0f), kNear); }

TEST(TriangleSampling, AreaStrategyFarFromTheLight) {
  const Triangle t{{0, 0, 2}, {0.02f, 0, 2}, {0, 0.02f, 2}};
  ASSERT_LT(solid_angle(glm::vec3(0.0f), t), kMinSolidAngle);
  check_strategy(glm::vec3(0.0f), t);
}

TEST(TriangleSampling, NearTheLightTheEstimateIsBounded) {
  // A point 1 mm beside the light's plane, 1 mm outside its edge: by area, 1 / pdf (the solid
  // angle each sample stands for) reaches hundreds of times its mean; by solid angle it is the
  // solid angle itself, every time.
  const Triangle t{{0.001f, -0.5f, 0.001f}, {1.0f, -0.5f, 0.001f}, {0.001f, 0.5f, 0.001f}};
  const glm::vec3 x(0.0f);
  const float omega = solid_angle(x, t);
  ASSERT_GT(omega, kMinSolidAngle);
  Rng rng(1, 2);
  for (int k = 0; k < 1000; ++k) {
    TriangleSample s;
    ASSERT_TRUE(sample_triangle(x, t, {rng.uniform(), rng.uniform()}, &s));
    EXPECT_NEAR(1.0f / s.pdf, omega, 1e-5f * omega);
  }
}

TEST(TriangleSampling, PointInThePlaneOrDegenerateTriangleIsRefused) {
  TriangleSample s;
  const Triangle t{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  EXPECT_FALSE(sample_triangle(glm::vec3(2.0f, 2.0f, 0.0f), t, {0.3f, 0.6f}, &s));
  const Triangle line{{0, 0, 1}, {1, 0, 1}, {2, 0, 1}};
  EXPECT_FALSE(sample_triangle(glm::vec3(0.0f), line, {0.3f, 0.6f}, &s));
}

}  // namespace
}  // namespace dofcache::render
