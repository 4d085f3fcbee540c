// The environment as a light in the path tracer: the furnace test (a diffuse sphere inside a
// uniform environment), importance sampling against cosine sampling under a small sun, MIS of the
// two, the background, and the radiance cache holding environment light.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <vector>

#include "dofcache/cache/radiance_cache.h"
#include "dofcache/core/error.h"
#include "dofcache/render/environment.h"
#include "dofcache/render/renderer.h"
#include "dofcache/render/shading.h"
#include "dofcache/scene/accel.h"
#include "render/test_scenes.h"

namespace dofcache::render {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr float kAlbedo = 0.6f;
constexpr float kRadiance = 2.0f;

// A diffuse sphere of albedo 0.6, radius 1, 3 m in front of a camera at the origin.
scene::Scene furnace_scene() {
  scene::Scene s;
  s.materials = {testing::diffuse_material(glm::vec3(kAlbedo))};
  testing::add_sphere(s, glm::vec3(0.0f, 0.0f, -3.0f), 1.0f, 48, 0, 0);
  s.cameras.push_back(testing::origin_camera(1.2f));  // the sphere fills half the height
  return s;
}

std::shared_ptr<const Environment> uniform(float radiance) {
  return std::make_shared<Environment>(Environment::constant(glm::vec3(radiance)));
}

RenderSettings furnace_settings(int spp, cache::RadianceCache* cache = nullptr) {
  RenderSettings s;
  s.width = 32, s.height = 32, s.spp = spp, s.seed = 7, s.threads = 2;
  s.mode = Mode::Pinhole;
  s.shading.light_samples = 2, s.shading.gather_rays = 2, s.shading.bounces = 2;
  s.shading.specular_depth = 0;  // the diffuse lobe alone: (1 - F(n.v)) a E/pi
  s.shading.environment = uniform(kRadiance);
  s.lens = lens::ThinLens{0.05, 4.0, 3.0};
  s.cache.cache = cache;
  s.progress = Progress::Display::Never;
  return s;
}

// Mean and standard error of the red channel over the central 6x6 pixels (n.v > 0.94 there,
// so F(n.v) = 0.04 + 0.96 (1 - n.v)^5 = 0.04 to 1e-6).
void centre_stats(const image::Image& img, double* mean, double* se) {
  double sum = 0, sum2 = 0;
  int n = 0;
  for (int y = 13; y < 19; ++y)
    for (int x = 13; x < 19; ++x) {
      const double v = img.at(x, y, 0);
      sum += v, sum2 += v * v, ++n;
    }
  *mean = sum / n;
  *se = std::sqrt(std::max(0.0, sum2 / n - *mean * *mean) / n);
}

// Mean and standard error of the red channel of n independent estimates of E/pi at p (estimate k
// seeded from `seed` and k).
void diffuse_stats(const Shader& shader, const ShadingPoint& p, int n, std::uint64_t seed,
                   double* mean, double* se) {
  double sum = 0, sum2 = 0;
  RayCounters counters;
  for (int k = 0; k < n; ++k) {
    Rng rng(seed, static_cast<std::uint64_t>(k));
    const double v = shader.diffuse_illumination(p, hash_combine(seed, k), rng, counters).x;
    sum += v, sum2 += v * v;
  }
  *mean = sum / n;
  *se = std::sqrt(std::max(0.0, sum2 / n - *mean * *mean) / n);
}

// A convex sphere sees only the environment, so E/pi = L everywhere and the sphere shows
// (1 - F) a L: hand-computed, (1 - 0.04) x 0.6 x 2 = 1.152.
TEST(EnvironmentLight, FurnaceSphereShowsAlbedoTimesRadiance) {
  const scene::Scene s = furnace_scene();
  const scene::Accel accel(s);
  const RenderOutput out = render(s, accel, s.cameras[0], furnace_settings(16));
  double mean, se;
  centre_stats(out.color, &mean, &se);
  const double expected = 1.152;
  ASSERT_NEAR((1.0 - 0.04) * kAlbedo * kRadiance, expected, 1e-6);
  // 36 pixels x 16 samples: the tolerance is 4 standard errors of their mean, plus the sphere's
  // tessellation (the shading normal against the flat facet: under 0.1%).
  std::printf("furnace: centre %.5f (expected %.5f), standard error %.5f\n", mean, expected, se);
  EXPECT_NEAR(mean, expected, 4.0 * se + 1e-3 * expected) << "standard error " << se;
  EXPECT_LT(se, 0.02 * expected);
  // The background is the environment (visible by default).
  EXPECT_FLOAT_EQ(out.color.at(0, 0, 1), kRadiance);

  // E/pi itself at a point of the sphere, per strategy: light samples only, cosine rays only,
  // and both under MIS, each with 4000 estimates.
  for (auto [light, gather] : {std::pair{1, 0}, std::pair{0, 1}, std::pair{2, 2}}) {
    ShadingSettings settings;
    settings.light_samples = light, settings.gather_rays = gather, settings.bounces = 0;
    settings.environment = uniform(kRadiance);
    const Shader shader(s, accel, settings);
    scene::Ray ray;
    ray.direction = glm::normalize(glm::vec3(0.3f, 0.2f, -3.0f));
    const ShadingPoint p = shader.prepare(ray, accel.intersect(ray));
    double m, e;
    diffuse_stats(shader, p, 4000, 11, &m, &e);
    EXPECT_NEAR(m, kRadiance, 4.0 * e + 1e-4) << light << " light, " << gather << " gather";
  }
}

// A cached render of the furnace agrees with the uncached one, with either backend.
TEST(EnvironmentLight, CacheHoldsEnvironmentLight) {
  const scene::Scene s = furnace_scene();
  const scene::Accel accel(s);
  RenderSettings plain = furnace_settings(8);
  plain.mode = Mode::Drt;
  const RenderOutput reference = render(s, accel, s.cameras[0], plain);
  double ref_mean, ref_se;
  centre_stats(reference.color, &ref_mean, &ref_se);
  for (const char* backend : {"octree", "vdb"}) {
    auto cache = cache::make_radiance_cache(backend);
    RenderSettings cached = furnace_settings(8, cache.get());
    cached.mode = Mode::Drt;
    const RenderOutput out = render(s, accel, s.cameras[0], cached);
    double mean, se;
    centre_stats(out.color, &mean, &se);
    EXPECT_GT(out.stats.cache_hits + out.stats.cache_tile_hits, 0u) << backend;
    EXPECT_NEAR(mean, ref_mean, 4.0 * std::hypot(se, ref_se) + 0.01 * ref_mean) << backend;
    EXPECT_NEAR(mean, 1.152, 0.03 * 1.152) << backend;
  }
}

// 64 x 32 texels of dim sky (0.05) with a 2 x 2 texel sun of 5000 about 50 degrees above the
// horizon: about 97% of the light on a floor comes from 0.02% of the sphere.
image::Image sun_map() {
  image::Image m(64, 32, 3, 0.05f);
  for (int y = 6; y < 8; ++y)
    for (int x = 20; x < 22; ++x)
      for (int c = 0; c < 3; ++c) m.at(x, y, c) = 5000.0f;
  return m;
}

// E/pi at an upward-facing point under the map, by quadrature over the texels (each split into
// 32 x 32 parts): (1/pi) sum L cos(theta) dw. Independent of the sampling code.
double sun_reference(const image::Image& m) {
  double sum = 0.0;
  const int k = 32;
  for (int y = 0; y < m.height(); ++y)
    for (int sy = 0; sy < k; ++sy) {
      const double t0 = kPi * (y + double(sy) / k) / m.height();
      const double t1 = kPi * (y + double(sy + 1) / k) / m.height();
      if (t0 >= kPi / 2) continue;
      // Integral of cos(theta) sin(theta) dtheta over [t0, t1] = (sin^2 t1 - sin^2 t0) / 2.
      const double band = 0.5 * (std::pow(std::sin(std::min(t1, kPi / 2)), 2) -
                                 std::pow(std::sin(t0), 2));
      for (int x = 0; x < m.width(); ++x)
        sum += m.at(x, y, 0) * band * (2.0 * kPi / m.width());
    }
  return sum / kPi;
}

TEST(EnvironmentLight, ImportanceSamplingBeatsCosineSamplingUnderASmallSun) {
  // A large floor at y = 0 facing up: the shading point sees the upper hemisphere.
  scene::Scene s;
  s.materials = {testing::diffuse_material(glm::vec3(0.5f))};
  testing::add_quad(s, {glm::vec3(-50, 0, -50), glm::vec3(-50, 0, 50), glm::vec3(50, 0, 50),
                        glm::vec3(50, 0, -50)},
                    {0, 1, 0}, 0, 0);
  const scene::Accel accel(s);
  const image::Image map = sun_map();
  const double reference = sun_reference(map);
  auto env = std::make_shared<Environment>(Environment::lat_long(map, 1.0f, 0.3f));

  // Relative MSE of single-sample estimates of E/pi (one direction each) against the reference.
  auto rel_mse = [&](int light_samples, int gather_rays, double* mean) {
    ShadingSettings settings;
    settings.light_samples = light_samples, settings.gather_rays = gather_rays;
    settings.bounces = 0;
    settings.environment = env;
    const Shader shader(s, accel, settings);
    scene::Ray ray;
    ray.origin = glm::vec3(0.0f, 1.0f, 0.0f);
    ray.direction = glm::vec3(0.0f, -1.0f, 0.0f);
    const ShadingPoint p = shader.prepare(ray, accel.intersect(ray));
    const int n = 20000;
    double sum = 0.0, err = 0.0;
    RayCounters counters;
    for (int k = 0; k < n; ++k) {
      Rng rng(3, static_cast<std::uint64_t>(k));
      const double v = shader.diffuse_illumination(p, hash_combine(3, k), rng, counters).x;
      sum += v;
      err += (v - reference) * (v - reference);
    }
    *mean = sum / n;
    return err / n / (reference * reference);
  };
  double mean_is, mean_cos, mean_mis;
  const double is = rel_mse(1, 0, &mean_is);     // light (importance) sampling alone
  const double cos = rel_mse(0, 1, &mean_cos);   // cosine sampling alone
  const double mis = rel_mse(1, 1, &mean_mis);   // both, MIS (two directions per estimate)
  std::printf("E/pi reference %.4f; relMSE importance %.3g, cosine %.3g, MIS %.3g (ratio %.0f)\n",
              reference, is, cos, mis, cos / is);
  EXPECT_LT(is * 20.0, cos);
  EXPECT_LT(mis, cos);
  // Unbiased: the importance-sampled mean is within 1% (its relative standard error is
  // sqrt(relMSE / n), about 0.1%); MIS likewise. The cosine mean is too noisy to check tightly.
  EXPECT_NEAR(mean_is / reference, 1.0, 0.01);
  EXPECT_NEAR(mean_mis / reference, 1.0, 0.02);
  EXPECT_NEAR(mean_cos / reference, 1.0, 5.0 * std::sqrt(cos / 20000.0));
}

// With an environment and an emitter together, both are sampled and their sum is unbiased: a floor
// under a uniform sky of 0.5 and a panel of 4 hanging 0.5 above it, against the closed form.
TEST(EnvironmentLight, EnvironmentAndEmittersTogether) {
  scene::Scene s;
  s.materials = {testing::diffuse_material(glm::vec3(0.5f)),
                 testing::emissive_material(glm::vec3(4.0f))};
  testing::add_quad_z(s, -10, 10, -10, 10, 0.0f, 0, 0);
  testing::add_quad(s,
                    {glm::vec3(-0.25f, -0.25f, 0.5f), glm::vec3(-0.25f, 0.25f, 0.5f),
                     glm::vec3(0.25f, 0.25f, 0.5f), glm::vec3(0.25f, -0.25f, 0.5f)},
                    {0.0f, 0.0f, -1.0f}, 1, 1);
  testing::build_emitters(s);
  const scene::Accel accel(s);
  // The sky is blocked where the panel is (it is one-sided; from below it emits): E/pi from the
  // sky is L (1 - F), F the panel's form factor; from the panel 4 F.
  const double f = testing::rectangle_form_factor(-0.25, 0.25, -0.25, 0.25, 0.5);
  const double expected = 0.5 * (1.0 - f) + 4.0 * f;
  ShadingSettings settings;
  settings.light_samples = 2, settings.gather_rays = 2, settings.bounces = 0;
  settings.environment = std::make_shared<Environment>(Environment::constant(glm::vec3(0.5f)));
  const Shader shader(s, accel, settings);
  scene::Ray ray;
  ray.origin = glm::vec3(2.0f, 0.0f, 1.0f);  // passes beside the panel, hits the origin
  ray.direction = glm::normalize(glm::vec3(-2.0f, 0.0f, -1.0f));
  const ShadingPoint p = shader.prepare(ray, accel.intersect(ray));
  double m, e;
  diffuse_stats(shader, p, 8000, 5, &m, &e);
  EXPECT_NEAR(m, expected, 4.0 * e + 1e-3) << "standard error " << e;
}

// Determinism holds with an environment: a cached drt render under the sun map is the same for
// one and two threads.
TEST(EnvironmentLight, SameImageForAnyThreadCount) {
  const scene::Scene s = furnace_scene();
  const scene::Accel accel(s);
  RenderSettings settings = furnace_settings(4);
  settings.mode = Mode::Drt;
  settings.shading.environment =
      std::make_shared<Environment>(Environment::lat_long(sun_map(), 0.01f, 1.0f));
  auto c1 = cache::make_radiance_cache("vdb");
  auto c2 = cache::make_radiance_cache("vdb");
  settings.cache.cache = c1.get();
  settings.threads = 1;
  const RenderOutput a = render(s, accel, s.cameras[0], settings);
  settings.cache.cache = c2.get();
  settings.threads = 2;
  const RenderOutput b = render(s, accel, s.cameras[0], settings);
  EXPECT_EQ(a.color.data(), b.color.data());
}

TEST(EnvironmentLight, HiddenEnvironmentStillLights) {
  const scene::Scene s = furnace_scene();
  const scene::Accel accel(s);
  RenderSettings settings = furnace_settings(4);
  settings.shading.environment =
      std::make_shared<Environment>(Environment::constant(glm::vec3(kRadiance), false));
  const RenderOutput out = render(s, accel, s.cameras[0], settings);
  EXPECT_EQ(out.color.at(0, 0, 0), 0.0f);
  EXPECT_GT(out.color.at(16, 16, 0), 1.0f);
}

}  // namespace
}  // namespace dofcache::render

namespace dofcache::render {
namespace {

// MaterialOverride::Lambert: a metallic, glossy sphere in the furnace shows a L, hand-computed
// 0.6 x 2 = 1.2, at every pixel it covers, its rim included (no Fresnel weight, no specular lobe,
// metallic ignored).
TEST(EnvironmentLight, LambertOverrideShowsAlbedoTimesRadianceEverywhere) {
  scene::Scene s = furnace_scene();
  s.materials[0].metallic = 1.0f;
  s.materials[0].roughness = 0.3f;
  const scene::Accel accel(s);
  RenderSettings settings = furnace_settings(16);
  settings.shading.specular_depth = 3;
  settings.shading.material_override = MaterialOverride::Lambert;
  const RenderOutput out = render(s, accel, s.cameras[0], settings);
  double sum = 0, sum2 = 0;
  int n = 0;
  auto sphere = [&](int x, int y) { return out.ids.at(x, y, 0) >= 0.0f; };
  for (int y = 1; y + 1 < out.color.height(); ++y)
    for (int x = 1; x + 1 < out.color.width(); ++x)
      // Pixels wholly on the sphere: the centre and its four neighbours see it, so no sample
      // sees the background. Those next to the rim see it at grazing angles.
      if (sphere(x, y) && sphere(x - 1, y) && sphere(x + 1, y) && sphere(x, y - 1) &&
          sphere(x, y + 1)) {
        const double v = out.color.at(x, y, 0);
        sum += v, sum2 += v * v, ++n;
      }
  ASSERT_GT(n, 100);
  const double mean = sum / n, se = std::sqrt(std::max(0.0, sum2 / n - mean * mean) / n);
  // The tessellation's flat facets against the shading normal: well under 1%.
  EXPECT_NEAR(mean, 1.2, 4.0 * se + 0.01) << "standard error " << se;
  double centre, centre_se;
  centre_stats(out.color, &centre, &centre_se);
  EXPECT_NEAR(centre, 1.2, 4.0 * centre_se + 1.2e-3);

  // Without it the same metal has no diffuse lobe: with its specular lobe off too, it is black.
  settings.shading.material_override = MaterialOverride::None;
  settings.shading.specular_depth = 0;
  centre_stats(render(s, accel, s.cameras[0], settings).color, &centre, &centre_se);
  EXPECT_EQ(centre, 0.0);
  EXPECT_STREQ(material_override_name(parse_material_override("lambert")), "lambert");
  EXPECT_THROW(parse_material_override("phong"), Error);
}

}  // namespace
}  // namespace dofcache::render
