// Eqs. (4.3) and (4.4), the acceptance tests, and the canonical-order weighted sum.
#include "dofcache/cache/weights.h"

#include <gtest/gtest.h>

#include <cmath>

namespace dofcache::cache {
namespace {

const glm::vec3 kP(0.0f), kN(0.0f, 0.0f, 1.0f);

TEST(Weights, ErrorEq4_3) {
  // ||p - p_i|| = 0.5, n . n_i = 0.96, r_i = 1: eps = 0.5 / 0.96 = 0.5208333.
  glm::vec3 ni(0.0f, 0.28f, 0.96f);
  EXPECT_NEAR(sample_error(kP, kN, {0.3f, 0.4f, 0.0f}, ni, 1.0f), 0.5208333f, 1e-6f);
  // Same normal, r_i = 2: eps = 0.5 / 2 = 0.25.
  EXPECT_NEAR(sample_error(kP, kN, {0.3f, 0.4f, 0.0f}, kN, 2.0f), 0.25f, 1e-7f);
}

TEST(Weights, WeightEq4_4) {
  EXPECT_FLOAT_EQ(sample_weight(0.0f), 1.0f);
  EXPECT_FLOAT_EQ(sample_weight(0.25f), 0.5625f);
  EXPECT_NEAR(sample_weight(0.5208333f), 0.2296007f, 1e-6f);  // (1 - 0.5208333)^2
}

TEST(Weights, AcceptedSampleGetsEq4_4Weight) {
  SampleTest test(kP, kN, LookupOptions{});
  glm::vec3 ni(0.0f, -0.28f, 0.96f);  // 16.26 degrees from n, tilted towards p_i
  EXPECT_NEAR(test.weight({0.3f, 0.4f, 0.0f}, 1.0f, ni), 0.2296007f, 1e-6f);
}

TEST(Weights, RejectsBeyondTheRadius) {
  SampleTest test(kP, kN, LookupOptions{});
  EXPECT_EQ(test.weight({0.6f, 0.8f, 0.0f}, 1.0f, kN), 0.0f);   // distance 1 = r: eps = 1
  EXPECT_EQ(test.weight({0.6f, 0.8f, 0.0f}, 0.9f, kN), 0.0f);   // beyond
  // Within r but eps >= 1 once the normal term shrinks the reach: 0.95 / (1 * 0.94) > 1.
  float c = 0.94f, s = std::sqrt(1.0f - c * c);
  EXPECT_EQ(test.weight({0.95f, 0.0f, 0.0f}, 1.0f, {0.0f, s, c}), 0.0f);
  EXPECT_GT(test.weight({0.90f, 0.0f, 0.0f}, 1.0f, {0.0f, s, c}), 0.0f);
}

// An anamorphic oval's footprint: along the squeezed axis (x here) the reach is squeeze r or the
// in-focus floor, whichever is larger; across it the sphere's.
TEST(Weights, AnisotropicFootprintReachesSqueezeTimesTheRadiusAlongItsAxis) {
  LookupOptions o;
  o.footprint_squeeze = 0.5f;
  o.footprint_axis = {1.0f, 0.0f, 0.0f};
  o.camera_position = {0.0f, 0.0f, 4.0f};  // the query 4 m in front of the camera
  o.camera_forward = {0.0f, 0.0f, -1.0f};
  const SampleTest test(kP, kN, o);
  // 0.25 along x with r = 1: the offset counts 1 / 0.5 = 2 times, eps = 0.5, w = (1 - 0.5)^2.
  EXPECT_NEAR(test.weight({0.25f, 0.0f, 0.0f}, 1.0f, kN), 0.25f, 1e-6f);
  EXPECT_EQ(test.weight({0.55f, 0.0f, 0.0f}, 1.0f, kN), 0.0f);  // beyond 0.5 along x
  EXPECT_NEAR(test.weight({0.0f, 0.9f, 0.0f}, 1.0f, kN), 0.01f, 1e-6f);  // y: (1 - 0.9)^2
  // (0.3, 0.3): sqrt(0.09 + 0.09 + 3 x 0.09) = 0.6708.
  EXPECT_NEAR(test.weight({0.3f, 0.3f, 0.0f}, 1.0f, kN), std::pow(1.0f - 0.67082f, 2.0f), 1e-5f);
  // A floor of 0.2 per metre of depth: 0.8 at the query, so along x the reach is 0.8.
  o.floor_per_depth = 0.2f;
  const SampleTest floored(kP, kN, o);
  // 0.4 along x counts 1 / 0.8 = 1.25 times: eps = 0.5.
  EXPECT_NEAR(floored.weight({0.4f, 0.0f, 0.0f}, 1.0f, kN), 0.25f, 1e-6f);
  EXPECT_EQ(floored.weight({0.85f, 0.0f, 0.0f}, 1.0f, kN), 0.0f);
  // A round footprint is the paper's sphere.
  EXPECT_NEAR(SampleTest(kP, kN, LookupOptions{}).weight({0.25f, 0.0f, 0.0f}, 1.0f, kN), 0.5625f,
              1e-6f);
}

TEST(Weights, RejectsNormalsBeyondTheAngle) {
  LookupOptions opt;  // 25 degrees
  SampleTest test(kP, kN, opt);
  auto tilted = [](float deg) {
    float a = deg * 3.14159265f / 180.0f;
    return glm::vec3(0.0f, std::sin(a), std::cos(a));
  };
  EXPECT_GT(test.weight({0.01f, 0.0f, 0.0f}, 1.0f, tilted(24.0f)), 0.0f);
  EXPECT_EQ(test.weight({0.01f, 0.0f, 0.0f}, 1.0f, tilted(26.0f)), 0.0f);
  EXPECT_EQ(test.weight({0.01f, 0.0f, 0.0f}, 1.0f, -kN), 0.0f);  // back face
  opt.max_normal_angle_deg = 40.0f;
  EXPECT_GT(SampleTest(kP, kN, opt).weight({0.01f, 0.0f, 0.0f}, 1.0f, tilted(30.0f)), 0.0f);
}

TEST(Weights, RejectsSamplesInFront) {
  LookupOptions opt;
  // A sample 0.2 above the query's tangent plane (a ledge): (p - p_i) . (n + n_i) / 2 = -0.2,
  // below -0.05 r_i.
  EXPECT_EQ(SampleTest(kP, kN, opt).weight({0.3f, 0.0f, 0.2f}, 1.0f, kN), 0.0f);
  // Behind the plane is fine: eps = sqrt(0.13), weight (1 - 0.36056)^2.
  EXPECT_NEAR(SampleTest(kP, kN, opt).weight({0.3f, 0.0f, -0.2f}, 1.0f, kN), 0.40889f, 2e-5f);
  // Within the tolerance (0.04 < 0.05 r_i) it is kept.
  EXPECT_GT(SampleTest(kP, kN, opt).weight({0.3f, 0.0f, 0.04f}, 1.0f, kN), 0.0f);
  opt.reject_in_front = false;
  EXPECT_NEAR(SampleTest(kP, kN, opt).weight({0.3f, 0.0f, 0.2f}, 1.0f, kN), 0.40889f, 2e-5f);
}

TEST(Weights, InFrontTestIsNeutralOnSpheres) {
  // Points on a sphere (inside, concave): (p - p_i) . (n + n_i) = 0 exactly in exact arithmetic.
  glm::vec3 c(0.0f, 0.0f, 5.0f);
  glm::vec3 p(0.0f), n = glm::normalize(c - p);
  glm::vec3 pi = c + 5.0f * glm::normalize(glm::vec3(0.3f, 0.0f, -1.0f));
  glm::vec3 ni = glm::normalize(c - pi);
  EXPECT_GT(SampleTest(p, n, LookupOptions{}).weight(pi, 2.0f, ni), 0.0f);
}

TEST(WeightedSum, InterpolatesAndCountsAgainstMinSamples) {
  WeightedSum sum;
  sum.add(7, 0.25f, {4.0f, 0.0f, 0.0f});
  sum.add(3, 0.75f, {0.0f, 8.0f, 0.0f});
  LookupResult r;
  EXPECT_TRUE(sum.finish(2, &r));
  EXPECT_EQ(r.count, 2);
  EXPECT_FLOAT_EQ(r.weight_sum, 1.0f);
  EXPECT_FLOAT_EQ(r.value.x, 1.0f);
  EXPECT_FLOAT_EQ(r.value.y, 6.0f);
  WeightedSum again;
  again.add(1, 1.0f, glm::vec3(1.0f));
  EXPECT_FALSE(again.finish(2, &r));
  EXPECT_EQ(r.count, 1);
  EXPECT_FALSE(WeightedSum().finish(0, &r));  // nothing accepted never succeeds
}

TEST(WeightedSum, OrderOfAdditionDoesNotMatter) {
  // Many values of very different magnitudes, added forwards and backwards: the sum runs in id
  // order either way, so the results are bit-identical. 100 entries also exercise the overflow.
  WeightedSum a, b;
  for (std::uint32_t i = 0; i < 100; ++i) {
    float w = 1.0f / (1.0f + static_cast<float>(i * i % 17));
    glm::vec3 v(std::pow(10.0f, static_cast<float>(i % 9) - 4.0f), 0.1f * i, 1.0f);
    a.add(i, w, v);
    b.add(99 - i, 1.0f / (1.0f + static_cast<float>((99 - i) * (99 - i) % 17)),
          glm::vec3(std::pow(10.0f, static_cast<float>((99 - i) % 9) - 4.0f), 0.1f * (99 - i),
                    1.0f));
  }
  LookupResult ra, rb;
  a.finish(1, &ra);
  b.finish(1, &rb);
  EXPECT_EQ(ra.value.x, rb.value.x);
  EXPECT_EQ(ra.value.y, rb.value.y);
  EXPECT_EQ(ra.weight_sum, rb.weight_sum);
  EXPECT_EQ(ra.count, 100);
}

}  // namespace
}  // namespace dofcache::cache
