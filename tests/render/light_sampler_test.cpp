// LightSampler: the per-point choice of emitter against hand-computed probabilities, and the direct
// light it feeds against the closed-form irradiance of two rectangular lights.
#include "dofcache/render/light_sampler.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "dofcache/render/shading.h"
#include "dofcache/scene/accel.h"
#include "render/test_scenes.h"

namespace dofcache::render {
namespace {

// A one-sided light quad [x0, x1] x [y0, y1] in the plane z = h, facing -Z, radiance 1.
void add_ceiling_light(scene::Scene& s, float x0, float x1, float y0, float y1, float h,
                       std::uint32_t object) {
  testing::add_quad(
      s, {glm::vec3(x0, y0, h), glm::vec3(x0, y1, h), glm::vec3(x1, y1, h), glm::vec3(x1, y0, h)},
      {0.0f, 0.0f, -1.0f}, 1, object);
}

// A floor at z = 0 (object 0), a small light of half-size 0.02 at height 0.1 above the origin
// (object 1) and a large one, x in [2, 4], y in [-1, 1], at height 5 (object 2). Seen from the
// origin the two subtend similar irradiance, but the small one has 1/2500 of the power.
scene::Scene two_lights() {
  scene::Scene s;
  s.materials = {testing::diffuse_material(glm::vec3(0.5f)),
                 testing::emissive_material(glm::vec3(1.0f))};
  testing::add_quad_z(s, -10, 10, -10, 10, 0.0f, 0, 0);
  add_ceiling_light(s, -0.02f, 0.02f, -0.02f, 0.02f, 0.1f, 1);
  add_ceiling_light(s, 2.0f, 4.0f, -1.0f, 1.0f, 5.0f, 2);
  testing::build_emitters(s);
  return s;
}

float total_probability(const LightSampler& ls, std::size_t emitters, glm::vec3 x, glm::vec3 n) {
  float sum = 0.0f;
  for (std::size_t e = 0; e < emitters; ++e) sum += ls.probability(x, n, e);
  return sum;
}

TEST(LightSampler, WeighsLightsByPowerOverSquaredDistance) {
  scene::Scene s = two_lights();
  LightSampler ls(s);
  ASSERT_EQ(ls.light_count(), 2u);
  // Small light: power 0.0016 (area * luminance 1), centre at distance 0.1, radius 0.0283: weight
  // 0.0016 / 0.01 = 0.16. Large light: power 4, centre (3, 0, 5) at squared distance 34: 4 / 34 =
  // 0.117647. P(small) = 0.16 / 0.277647 = 0.576271, half of it per triangle.
  const glm::vec3 x(0.0f), n(0.0f, 0.0f, 1.0f);
  EXPECT_NEAR(ls.probability(x, n, 0), 0.576271f / 2, 1e-5f);
  EXPECT_NEAR(ls.probability(x, n, 1), 0.576271f / 2, 1e-5f);
  EXPECT_NEAR(ls.probability(x, n, 2), 0.423729f / 2, 1e-5f);
  EXPECT_NEAR(total_probability(ls, s.emitters.size(), x, n), 1.0f, 1e-6f);
  // Power alone would give the small light 0.0016 / 4.0016 = 0.0004.
  EXPECT_NEAR(s.emitter_cdf[1], 0.0016f / 4.0016f, 1e-6f);

  // sample() reports the probability that probability() gives, and its frequencies follow it.
  std::vector<int> count(s.emitters.size(), 0);
  const int kDraws = 4000;
  for (int k = 0; k < kDraws; ++k) {
    std::size_t e = 99;
    float p = -1.0f;
    ASSERT_TRUE(ls.sample(x, n, (k + 0.5f) / kDraws, &e, &p));
    ASSERT_LT(e, s.emitters.size());
    EXPECT_FLOAT_EQ(p, ls.probability(x, n, e));
    ++count[e];
  }
  for (std::size_t e = 0; e < s.emitters.size(); ++e)
    EXPECT_NEAR(count[e] / static_cast<double>(kDraws), ls.probability(x, n, e), 2e-3);
}

TEST(LightSampler, NeverPicksALightThatCannotReachThePoint) {
  scene::Scene s = two_lights();
  LightSampler ls(s);
  std::size_t e;
  float p;
  // Facing down at the origin: both lights lie wholly below the horizon.
  EXPECT_FALSE(ls.sample(glm::vec3(0.0f), glm::vec3(0.0f, 0.0f, -1.0f), 0.5f, &e, &p));
  EXPECT_EQ(ls.probability(glm::vec3(0.0f), glm::vec3(0.0f, 0.0f, -1.0f), 0), 0.0f);
  // Above the small light, behind its lit side: only the large light remains.
  const glm::vec3 above(0.0f, 0.0f, 0.2f), up(0.0f, 0.0f, 1.0f);
  EXPECT_EQ(ls.probability(above, up, 0), 0.0f);
  EXPECT_EQ(ls.probability(above, up, 1), 0.0f);
  EXPECT_NEAR(ls.probability(above, up, 2) + ls.probability(above, up, 3), 1.0f, 1e-6f);
  // A point on its lit side, beside it, facing it: still eligible.
  EXPECT_GT(ls.probability(glm::vec3(0.5f, 0.0f, 0.05f), glm::vec3(-1.0f, 0.0f, 0.0f), 0), 0.0f);
}

TEST(LightSampler, OneLightIsPowerSampling) {
  scene::Scene s;
  s.materials = {testing::diffuse_material(glm::vec3(0.5f)),
                 testing::emissive_material(glm::vec3(1.0f, 0.5f, 0.2f))};
  add_ceiling_light(s, 0, 1, 0, 1, 2.0f, 0);
  add_ceiling_light(s, 2, 4, 0, 1, 2.0f,
                    0);  // same object: one light of four triangles
  testing::build_emitters(s);
  LightSampler ls(s);
  ASSERT_EQ(ls.light_count(), 1u);
  for (float u : {0.0f, 0.1f, 0.3f, 0.55f, 0.99f}) {
    std::size_t e;
    float p, q;
    ASSERT_TRUE(ls.sample(glm::vec3(5.0f), glm::vec3(1.0f, 0.0f, 0.0f), u, &e, &p));
    EXPECT_EQ(e, s.sample_emitter(u, &q));
    EXPECT_EQ(p, q);
  }
}

TEST(LightSampler, ManyLightsAreClustered) {
  scene::Scene s;
  s.materials = {testing::diffuse_material(glm::vec3(0.5f)),
                 testing::emissive_material(glm::vec3(1.0f))};
  for (int i = 0; i < 150; ++i) {
    float x = static_cast<float>(i % 15), y = static_cast<float>(i / 15);
    add_ceiling_light(s, x, x + 0.5f, y, y + 0.5f, 3.0f, static_cast<std::uint32_t>(i));
  }
  testing::build_emitters(s);
  LightSampler ls(s);
  EXPECT_EQ(ls.light_count(), static_cast<std::size_t>(LightSampler::kMaxLights));
  const glm::vec3 x(7.0f, 5.0f, 0.0f), n(0.0f, 0.0f, 1.0f);
  EXPECT_NEAR(total_probability(ls, s.emitters.size(), x, n), 1.0f, 1e-5f);
  for (std::size_t e = 0; e < s.emitters.size(); ++e) EXPECT_GT(ls.probability(x, n, e), 0.0f);
}

TEST(LightSampler, DirectLightMatchesClosedFormWithoutFireflies) {
  scene::Scene s = two_lights();
  scene::Accel accel(s);
  ShadingSettings settings;
  settings.light_samples = 4;
  settings.gather_rays = 0;
  Shader shader(s, accel, settings);
  // The floor at the origin, reached past the small light.
  scene::Ray ray;
  ray.origin = glm::vec3(0.5f, 0.0f, 1.0f);
  ray.direction = glm::normalize(glm::vec3(-0.5f, 0.0f, -1.0f));
  scene::Hit hit = accel.intersect(ray);
  ASSERT_TRUE(hit.valid());
  ShadingPoint p = shader.prepare(ray, hit);
  ASSERT_NEAR(glm::length(p.surface.position), 0.0f, 1e-4f);

  const double expected = testing::rectangle_form_factor(-0.02, 0.02, -0.02, 0.02, 0.1) +
                          testing::rectangle_form_factor(2, 4, -1, 1, 5);  // E / pi, radiance 1
  ASSERT_NEAR(expected, 0.0757, 5e-4);                            // small 0.0484, large 0.0273
  const int kEstimates = 2000;
  double sum = 0, sum2 = 0;
  RayCounters counters;
  for (int k = 0; k < kEstimates; ++k) {
    Rng rng(17, static_cast<std::uint64_t>(k));
    double v =
        shader.diffuse_illumination(p, static_cast<std::uint64_t>(k) * 7919u, rng, counters).x;
    sum += v;
    sum2 += v * v;
  }
  const double mean = sum / kEstimates;
  const double sd = std::sqrt(std::max(0.0, sum2 / kEstimates - mean * mean));
  EXPECT_NEAR(mean / expected, 1.0, 0.03);
  // Power sampling picks the small light 0.04% of the time: its estimates have a relative standard
  // deviation of about 16. Weighing by distance brings it under 1.
  EXPECT_LT(sd / mean, 1.0);
}

}  // namespace
}  // namespace dofcache::render
