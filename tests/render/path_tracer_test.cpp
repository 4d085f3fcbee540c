// Light transport next to a light: every sampling strategy (light samples, cosine-weighted rays,
// both under multiple importance sampling) against the closed-form irradiance of a panel hanging
// 2 cm above the shading point, bounded estimates, error falling as 1/N, and a rendered
// hanging-light room without fireflies.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "dofcache/render/renderer.h"
#include "dofcache/render/shading.h"
#include "dofcache/scene/accel.h"
#include "dofcache/scene/gltf_loader.h"
#include "render/test_scenes.h"

namespace dofcache::render {
namespace {

// A floor at z = 0 and a one-sided panel of radiance 1 facing down, x in [0.01, 0.51],
// y in [-0.25, 0.25], hanging 2 cm above it: the origin is 1 cm outside the panel's edge.
scene::Scene hanging_panel() {
  scene::Scene s;
  s.materials = {testing::diffuse_material(glm::vec3(0.5f)),
                 testing::emissive_material(glm::vec3(1.0f))};
  testing::add_quad_z(s, -10, 10, -10, 10, 0.0f, 0, 0);
  testing::add_quad(s,
                    {glm::vec3(0.01f, -0.25f, 0.02f), glm::vec3(0.01f, 0.25f, 0.02f),
                     glm::vec3(0.51f, 0.25f, 0.02f), glm::vec3(0.51f, -0.25f, 0.02f)},
                    {0.0f, 0.0f, -1.0f}, 1, 1);
  testing::build_emitters(s);
  return s;
}

const double kExpected = testing::rectangle_form_factor(0.01, 0.51, -0.25, 0.25, 0.02);

struct Fixture {
  scene::Scene scene = hanging_panel();
  scene::Accel accel{scene};
  ShadingPoint point(const Shader& shader) const {
    scene::Ray ray;
    ray.origin = glm::vec3(-0.3f, 0.0f, 1.0f);
    ray.direction = glm::normalize(glm::vec3(0.3f, 0.0f, -1.0f));
    scene::Hit hit = accel.intersect(ray);
    EXPECT_TRUE(hit.valid());
    return shader.prepare(ray, hit);
  }
};

ShadingSettings direct_only(int light_samples, int gather_rays) {
  ShadingSettings s;
  s.light_samples = light_samples;
  s.gather_rays = gather_rays;
  s.bounces = 0;  // direct light only, as the closed form
  return s;
}

struct Moments {
  double mean = 0, sd = 0, max = 0;
};

Moments estimate(const Fixture& f, const ShadingSettings& settings, int n, std::uint64_t seed) {
  Shader shader(f.scene, f.accel, settings);
  const ShadingPoint p = f.point(shader);
  double sum = 0, sum2 = 0, max = 0;
  RayCounters counters;
  for (int k = 0; k < n; ++k) {
    Rng rng(seed, static_cast<std::uint64_t>(k));
    const double v = shader.diffuse_illumination(p, hash_combine(seed, k), rng, counters).x;
    sum += v;
    sum2 += v * v;
    max = std::max(max, v);
  }
  Moments m;
  m.mean = sum / n;
  m.sd = std::sqrt(std::max(0.0, sum2 / n - m.mean * m.mean));
  m.max = max;
  return m;
}

TEST(PathTracer, EveryStrategyMatchesTheClosedFormNextToALight) {
  ASSERT_NEAR(kExpected, 0.27471, 1e-4);  // h^2 / (pi r^4) integrated numerically over the panel
  Fixture f;
  const struct {
    int light, gather;
  } strategies[] = {{1, 0}, {0, 1}, {1, 1}, {4, 16}};
  for (auto s : strategies) {
    const Moments m = estimate(f, direct_only(s.light, s.gather), 6000, 5);
    const double standard_error = m.sd / std::sqrt(6000.0);
    EXPECT_NEAR(m.mean, kExpected, 4.0 * standard_error + 1e-3 * kExpected)
        << s.light << " light samples, " << s.gather << " gather rays, mean " << m.mean
        << " sd " << m.sd;
  }
}

TEST(PathTracer, LightSamplesNextToALightAreBounded) {
  // By area, a sample 1 cm from the panel's edge could weigh (2 cm)^-2 / pdf: hundreds of times
  // the mean. By solid angle with MIS, no estimate exceeds a few times the mean. (What variance
  // remains comes from the cosine at the receiver and from choosing the panel's two triangles by
  // power although one subtends far more than the other.)
  Fixture f;
  for (auto settings : {direct_only(1, 0), direct_only(1, 1)}) {
    const Moments m = estimate(f, settings, 6000, 9);
    EXPECT_LT(m.sd / m.mean, 1.5);
    EXPECT_LT(m.max / m.mean, 5.0);
  }
}

// A cache sample's refinement (Shader::refined_diffuse_illumination) doubles the rounds of its
// light samples and of its gather rays separately, each averaged with the MIS weights of one
// round: the estimate stays on the closed form and its spread falls, whichever strategies exist.
// Stopping on the data biases the mean slightly (measured here: -3% to +2% at the renderer's
// relative error 0.2, skewed light-only estimates the most).
TEST(PathTracer, RefinedEstimatesStayOnTheClosedFormWithLessSpread) {
  Fixture f;
  const float kError = 0.2f;  // CacheSettings::sample_error
  for (auto settings :
       {direct_only(4, 32), direct_only(4, 0), direct_only(0, 32), direct_only(2, 8)}) {
    Shader shader(f.scene, f.accel, settings);
    const ShadingPoint p = f.point(shader);
    const int n = 3000;
    double sum = 0, sum2 = 0;
    RayCounters refined_rays;
    for (int k = 0; k < n; ++k) {
      Rng rng(17, static_cast<std::uint64_t>(k));
      const double v = shader
                           .refined_diffuse_illumination(p, hash_combine(17, k), rng, refined_rays,
                                                         nullptr, kError, 8)
                           .x;
      sum += v, sum2 += v * v;
    }
    const double mean = sum / n, sd = std::sqrt(std::max(0.0, sum2 / n - mean * mean));
    const Moments plain = estimate(f, settings, n, 17);
    EXPECT_NEAR(mean, kExpected, 4.0 * sd / std::sqrt(double(n)) + 0.03 * kExpected)
        << settings.light_samples << " light samples, " << settings.gather_rays << " gather rays";
    EXPECT_LT(sd, 0.7 * plain.sd) << settings.light_samples << ", " << settings.gather_rays;
  }
}

TEST(PathTracer, ErrorFallsAsOneOverN) {
  // The mean squared error of an average of N independent estimates falls as 1/N only if their
  // variance is finite; heavy tails (unbounded variance) show as a shallower slope.
  Fixture f;
  Shader shader(f.scene, f.accel, direct_only(1, 1));
  const ShadingPoint p = f.point(shader);
  RayCounters counters;
  std::vector<double> log_n, log_mse;
  std::uint64_t stream = 0;
  for (int n : {1, 4, 16, 64}) {
    const int repetitions = 1500;
    double se = 0;
    for (int r = 0; r < repetitions; ++r) {
      double sum = 0;
      for (int k = 0; k < n; ++k, ++stream) {
        Rng rng(21, stream);
        sum += shader.diffuse_illumination(p, hash_combine(21, stream), rng, counters).x;
      }
      se += (sum / n - kExpected) * (sum / n - kExpected);
    }
    log_n.push_back(std::log(double(n)));
    log_mse.push_back(std::log(se / repetitions));
  }
  double mx = 0, my = 0;
  for (std::size_t i = 0; i < log_n.size(); ++i) mx += log_n[i] / 4, my += log_mse[i] / 4;
  double sxy = 0, sxx = 0;
  for (std::size_t i = 0; i < log_n.size(); ++i)
    sxy += (log_n[i] - mx) * (log_mse[i] - my), sxx += (log_n[i] - mx) * (log_n[i] - mx);
  const double slope = sxy / sxx;
  EXPECT_NEAR(slope, -1.0, 0.12);
}

// A rough dielectric's specular lobe at a camera hit, evaluated on a fraction of the rays and
// weighted by the inverse, has the mean of the lobe evaluated on every ray, for far fewer rays.
TEST(PathTracer, RoughLobeOnAFractionOfTheRaysIsUnbiased) {
  Fixture f;
  struct Result {
    double mean = 0, standard_error = 0;
    std::uint64_t rays = 0;
  };
  auto specular = [&](float rate) {
    ShadingSettings settings = direct_only(1, 1);
    settings.rough_lobe_rate = rate;
    Shader shader(f.scene, f.accel, settings);
    const ShadingPoint p = f.point(shader);
    RayCounters counters;
    const int n = 200000;
    double sum = 0, sum2 = 0;
    for (int k = 0; k < n; ++k) {
      Rng rng(31, static_cast<std::uint64_t>(k));
      const double v =
          shader.shade(p, glm::vec3(0.0f), rng.uniform(), rng, counters).x;  // the lobe alone
      sum += v, sum2 += v * v;
    }
    Result r;
    r.mean = sum / n;
    r.standard_error = std::sqrt(std::max(0.0, sum2 / n - r.mean * r.mean) / n);
    r.rays = counters.rays;
    return r;
  };
  const Result every = specular(0.0f), fraction = specular(0.5f);
  ASSERT_GT(every.mean, 0.0);
  const double se = std::hypot(every.standard_error, fraction.standard_error);
  EXPECT_NEAR(fraction.mean, every.mean, 4.0 * se) << "every ray " << every.mean << ", fraction "
                                                   << fraction.mean;
  EXPECT_LT(se / every.mean, 0.02);  // fine enough to resolve a bias of a few percent
  EXPECT_LT(static_cast<double>(fraction.rays), 0.3 * static_cast<double>(every.rays));
}

// A rough dielectric floor seen head-on under a panel out of view: its lobe's share is 0.077, so
// at rate 0.5 each lens sample evaluates it with probability 1/16 (the floor), weighted by 16.
// The renderer decides by each pixel's stratified pattern, so 16 samples evaluate it exactly
// once in every pixel; independent coins would leave (15/16)^16 = 36 % of the pixels without it.
// The image's mean stays that of evaluating the lobe on every sample.
TEST(PathTracer, RoughLobeDecisionsAreStratifiedPerPixelAndUnbiased) {
  scene::Scene s;
  s.materials = {testing::diffuse_material(glm::vec3(0.5f)),
                 testing::emissive_material(glm::vec3(5.0f))};
  testing::add_quad_z(s, -2, 2, -2, 2, -1.0f, 0, 0);
  testing::add_quad(s,
                    {glm::vec3(0.3f, -0.3f, -0.6f), glm::vec3(0.3f, 0.3f, -0.6f),
                     glm::vec3(0.9f, 0.3f, -0.6f), glm::vec3(0.9f, -0.3f, -0.6f)},
                    {0.0f, 0.0f, -1.0f}, 1, 1);
  testing::build_emitters(s);
  const scene::Accel accel(s);
  const scene::Camera camera = testing::origin_camera(0.3f);
  RenderSettings settings;
  settings.width = 24;
  settings.height = 16;
  settings.spp = 16;
  settings.mode = Mode::Pinhole;
  settings.threads = 2;
  settings.progress = Progress::Display::Never;
  settings.shading.light_samples = 256;  // the diffuse term all but exact: the lobe is the noise
  settings.shading.gather_rays = 0;
  settings.shading.bounces = 0;
  auto luminance_of = [&](float rate, int specular_depth, std::uint64_t seed) {
    RenderSettings r = settings;
    r.shading.rough_lobe_rate = rate;
    r.shading.specular_depth = specular_depth;
    r.seed = seed;
    const image::Image im = render(s, accel, camera, r).color;
    std::vector<double> v;
    for (int y = 0; y < im.height(); ++y)
      for (int x = 0; x < im.width(); ++x) v.push_back(im.at(x, y, 1));  // grey: one channel
    return v;
  };
  // One seed: the diffuse term, estimated before the lobe, is the same in all three, so the
  // differences are the lobe's estimates alone.
  const std::vector<double> fraction = luminance_of(0.5f, 3, 1), every = luminance_of(0.0f, 3, 1),
                            diffuse = luminance_of(0.0f, 0, 1);
  const double n = static_cast<double>(fraction.size());
  double lobe_mean = 0, diff = 0, diff2 = 0;
  for (std::size_t i = 0; i < fraction.size(); ++i) {
    lobe_mean += (every[i] - diffuse[i]) / n;
    const double d = fraction[i] - every[i];
    diff += d / n, diff2 += d * d / n;
  }
  ASSERT_GT(lobe_mean, 0.0);
  int without_lobe = 0;  // pixels whose lobe estimate is under a tenth of the every-sample one
  for (std::size_t i = 0; i < fraction.size(); ++i)
    without_lobe += fraction[i] - diffuse[i] < 0.1 * (every[i] - diffuse[i]);
  EXPECT_EQ(without_lobe, 0) << "of " << n << " pixels";
  const double standard_error = std::sqrt(std::max(0.0, diff2 - diff * diff) / n);
  EXPECT_NEAR(diff, 0.0, 4.0 * standard_error + 1e-6) << "lobe mean " << lobe_mean;
  EXPECT_LT(standard_error, 0.05 * lobe_mean);  // fine enough to see a bias of a fifth of it
}

// The shipped hanging-light room, rendered small: against a converged reference, no pixel may be
// a firefly, more than ten times the image's mean above the reference. Measured at 40x30 and
// 32 lens samples with one light sample and one gather ray: by area without MIS, pixels stood
// 273 and 49 means above; now the largest excess is 5.3, a pixel at the panel's blurred edge
// (honest lens noise: one hit on the panel more than its share), and rare bright paths off the
// ceiling just above the panel reach about 2.
TEST(PathTracer, HangingLightRoomHasNoFireflies) {
  scene::Scene scene =
      scene::load_gltf(std::string(DOFCACHE_SOURCE_DIR) + "/scenes/hanging_light_box.gltf");
  scene::Accel accel(scene);
  RenderSettings settings;
  settings.width = 40;
  settings.height = 30;
  settings.threads = 2;
  settings.progress = Progress::Display::Never;
  settings.shading.light_samples = 1;
  settings.shading.gather_rays = 1;
  settings.lens = lens::ThinLens{0.05, 0.2, 3.654};
  settings.spp = 1024;
  const image::Image reference = render(scene, accel, scene.cameras[0], settings).color;
  settings.spp = 32;
  settings.seed = 77;
  const image::Image img = render(scene, accel, scene.cameras[0], settings).color;
  double mean = 0;
  for (float v : reference.data()) mean += v;
  mean /= static_cast<double>(reference.data().size());
  int fireflies = 0;
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x)
      for (int c = 0; c < 3; ++c) {
        const double excess = img.at(x, y, c) - reference.at(x, y, c);
        if (excess <= 10.0 * mean) continue;
        ++fireflies;
        ADD_FAILURE() << "pixel (" << x << ", " << y << ") channel " << c << ": "
                      << img.at(x, y, c) << " against " << reference.at(x, y, c);
      }
  EXPECT_EQ(fireflies, 0);
}

}  // namespace
}  // namespace dofcache::render

namespace dofcache::render {
namespace {

// E/pi of a radiance-1 convex polygon at the origin with normal n, by Lambert's formula: the sum
// over the edges of the angle each subtends times n . (unit normal of the edge's plane), / 2 pi.
double polygon_form_factor(const std::vector<glm::dvec3>& v, glm::dvec3 n) {
  double sum = 0;
  for (std::size_t i = 0; i < v.size(); ++i) {
    const glm::dvec3 a = glm::normalize(v[i]), b = glm::normalize(v[(i + 1) % v.size()]);
    const glm::dvec3 c = glm::cross(a, b);
    sum += std::acos(std::clamp(glm::dot(a, b), -1.0, 1.0)) * glm::dot(n, glm::normalize(c));
  }
  return std::abs(sum) / (2.0 * 3.14159265358979323846);
}

// The hanging-light room's geometry: a two-sided panel 2 cm below the ceiling, seen from the top of
// the back wall, between the panel's plane and the ceiling: every light sample and cosine ray
// meets the panel's upper face at a grazing angle. Each strategy against the closed form.
TEST(PathTracer, GrazingLightFromATwoSidedPanelMatchesTheClosedForm) {
  scene::Scene s;
  s.materials = {testing::diffuse_material(glm::vec3(0.5f)),
                 testing::emissive_material(glm::vec3(1.0f))};
  s.materials[1].double_sided = true;
  // The back wall at z = -2 facing +z, and the panel at y = 1.98 (x, z within 0.25 of (0, -1)).
  testing::add_quad(s,
                    {glm::vec3(-1, 0, -2), glm::vec3(1, 0, -2), glm::vec3(1, 2, -2),
                     glm::vec3(-1, 2, -2)},
                    {0.0f, 0.0f, 1.0f}, 0, 0);
  testing::add_quad(s,
                    {glm::vec3(-0.25f, 1.98f, -1.25f), glm::vec3(0.25f, 1.98f, -1.25f),
                     glm::vec3(0.25f, 1.98f, -0.75f), glm::vec3(-0.25f, 1.98f, -0.75f)},
                    {0.0f, -1.0f, 0.0f}, 1, 1);
  testing::build_emitters(s);
  const scene::Accel accel(s);
  for (float height : {1.99f, 1.97f, 1.9f}) {  // above the panel's plane, below it, further down
    const glm::dvec3 p(0.0, height, -2.0);
    std::vector<glm::dvec3> corners;
    for (glm::vec3 c : {glm::vec3(-0.25f, 1.98f, -1.25f), glm::vec3(0.25f, 1.98f, -1.25f),
                        glm::vec3(0.25f, 1.98f, -0.75f), glm::vec3(-0.25f, 1.98f, -0.75f)})
      corners.push_back(glm::dvec3(c) - p);
    const double expected = polygon_form_factor(corners, {0.0, 0.0, 1.0});
    for (auto [light, gather] : {std::pair{1, 0}, std::pair{0, 1}, std::pair{1, 1}}) {
      Shader shader(s, accel, direct_only(light, gather));
      scene::Ray ray;
      ray.origin = glm::vec3(0.0f, height, 0.0f);
      ray.direction = glm::vec3(0.0f, 0.0f, -1.0f);
      const ShadingPoint sp = shader.prepare(ray, accel.intersect(ray));
      double sum = 0, sum2 = 0;
      const int n = 40000;
      RayCounters counters;
      for (int k = 0; k < n; ++k) {
        Rng rng(3, static_cast<std::uint64_t>(k));
        const double v = shader.diffuse_illumination(sp, hash_combine(3, k), rng, counters).x;
        sum += v, sum2 += v * v;
      }
      const double mean = sum / n, se = std::sqrt(std::max(0.0, sum2 / n - mean * mean) / n);
      EXPECT_NEAR(mean, expected, 4.0 * se + 1e-3 * expected)
          << "height " << height << ", " << light << " light samples, " << gather
          << " gather rays: " << mean << " against " << expected << " (se " << se << ")";
    }
  }
}

}  // namespace
}  // namespace dofcache::render
