// The environment light: its density integrates to one and matches its samples, rotation turns
// the map about +Y, bad files are refused in one line, and the default sky is given exactly to
// scenes without light.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <string>

#include "dofcache/core/error.h"
#include "dofcache/core/rng.h"
#include "dofcache/image/image_io.h"
#include "dofcache/render/environment.h"
#include "render/test_scenes.h"
#include "scratch_dir.h"

namespace dofcache::render {
namespace {

constexpr double kPi = 3.14159265358979323846;

// 64 x 32 texels: a dim sky brighter towards the zenith, a few coloured texels and a small sun
// (2 x 2 texels of 500) at azimuth 0 (towards -Z), elevation about 30 degrees.
image::Image test_map() {
  image::Image m(64, 32, 3);
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 64; ++x) {
      const float up = 1.0f - static_cast<float>(y) / 32.0f;
      m.at(x, y, 0) = 0.02f + 0.05f * up;
      m.at(x, y, 1) = 0.03f + 0.05f * up;
      m.at(x, y, 2) = 0.05f + 0.08f * up + (x % 7 == 0 ? 0.2f : 0.0f);
    }
  for (int y = 10; y < 12; ++y)
    for (int x = 31; x < 33; ++x)
      for (int c = 0; c < 3; ++c) m.at(x, y, c) = 500.0f;
  return m;
}

// Exact integral of luminance(L) over the sphere: each texel covers (2 pi / W)(cos t0 - cos t1).
double exact_luminance_integral(const image::Image& m, float strength) {
  double sum = 0.0;
  for (int y = 0; y < m.height(); ++y) {
    const double t0 = kPi * y / m.height(), t1 = kPi * (y + 1) / m.height();
    const double omega = 2.0 * kPi / m.width() * (std::cos(t0) - std::cos(t1));
    for (int x = 0; x < m.width(); ++x)
      sum += omega * strength *
             scene::luminance({m.at(x, y, 0), m.at(x, y, 1), m.at(x, y, 2)});
  }
  return sum;
}

// The second coordinate of a rank-1 lattice, k x step mod 1, in double (in float, k x step loses
// the fraction's low bits once k is large).
float lattice(int k, double offset = 0.0, double step = 0.7548776662466927) {
  return static_cast<float>(std::fmod(offset + k * step, 1.0));
}

glm::vec3 uniform_direction(Rng& rng) {
  const float z = 1.0f - 2.0f * rng.uniform(), phi = 2.0f * static_cast<float>(kPi) * rng.uniform();
  const float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
  return {r * std::cos(phi), z, r * std::sin(phi)};
}

TEST(Environment, PdfIntegratesToOneOverTheSphere) {
  const Environment e = Environment::lat_long(test_map(), 1.0f, 0.7f);
  // Monte Carlo with uniform directions: E[pdf / (1 / 4 pi)] = integral of pdf = 1.
  Rng rng(5, 0);
  const int n = 1 << 21;
  double sum = 0.0, sum2 = 0.0;
  for (int k = 0; k < n; ++k) {
    const double v = e.pdf(uniform_direction(rng)) * 4.0 * kPi;
    sum += v, sum2 += v * v;
  }
  const double mean = sum / n, se = std::sqrt((sum2 / n - mean * mean) / n);
  EXPECT_NEAR(mean, 1.0, 4.0 * se + 1e-3) << "standard error " << se;
  EXPECT_LT(se, 0.02);
}

TEST(Environment, SamplesFollowTheirPdf) {
  const image::Image map = test_map();
  const Environment e = Environment::lat_long(map, 2.0f, -1.3f);
  // E[1 / pdf] over samples is the solid angle of the support (all 4 pi: no texel is black), and
  // E[L / pdf] the integral of L: both fail if the samples do not follow pdf().
  const int n = 1 << 18;
  double inv = 0.0, lum = 0.0;
  for (int k = 0; k < n; ++k) {
    glm::vec3 wi, radiance;
    float pdf;
    const glm::vec2 u((k + 0.5f) / n, lattice(k, 0.5 / n, 0.6180339887498949));
    ASSERT_TRUE(e.sample(u, &wi, &pdf, &radiance));
    ASSERT_NEAR(glm::length(wi), 1.0f, 1e-5f);
    ASSERT_EQ(pdf, e.pdf(wi));
    ASSERT_EQ(radiance, e.radiance(wi));
    inv += 1.0 / pdf;
    lum += scene::luminance(radiance) / pdf;
  }
  EXPECT_NEAR(inv / n / (4.0 * kPi), 1.0, 0.01);
  const double exact = exact_luminance_integral(map, 2.0f);
  EXPECT_NEAR(lum / n / exact, 1.0, 0.002);
  // The sun holds most of the light, so most samples go there.
  int sun = 0;
  for (int k = 0; k < 1000; ++k) {
    glm::vec3 wi, radiance;
    float pdf;
    e.sample(glm::vec2((k + 0.5f) / 1000.0f, lattice(k)), &wi, &pdf, &radiance);
    sun += radiance.x > 100.0f;
  }
  EXPECT_GT(sun, 800);
}

TEST(Environment, RotationTurnsTheMapAboutTheVerticalAxis) {
  // The sun's centre: the texel corner (32, 11), i.e. u = 0.5 (azimuth 0: -Z), v = 11/32.
  const double theta = kPi * 11.0 / 32.0;
  const glm::vec3 sun_local(0.0f, static_cast<float>(std::cos(theta)),
                            static_cast<float>(-std::sin(theta)));
  const Environment still = Environment::lat_long(test_map(), 1.0f, 0.0f);
  EXPECT_GT(still.radiance(sun_local).x, 100.0f);
  // Turned by +90 degrees (right-handed about +Y), a sun towards -Z moves towards -X.
  const Environment turned = Environment::lat_long(test_map(), 1.0f, static_cast<float>(kPi / 2));
  const glm::vec3 sun_turned(static_cast<float>(-std::sin(theta)),
                             static_cast<float>(std::cos(theta)), 0.0f);
  EXPECT_LT(turned.radiance(sun_local).x, 1.0f);
  EXPECT_GT(turned.radiance(sun_turned).x, 100.0f);
  // Its samples follow: their mean direction points at the sun.
  glm::vec3 mean(0.0f);
  for (int k = 0; k < 4096; ++k) {
    glm::vec3 wi, radiance;
    float pdf;
    turned.sample(glm::vec2((k + 0.5f) / 4096.0f, lattice(k)), &wi, &pdf, &radiance);
    if (radiance.x > 100.0f) mean += wi;
  }
  mean = glm::normalize(mean);
  EXPECT_GT(glm::dot(mean, sun_turned), 0.995f);
  // Strength scales the radiance.
  const Environment bright = Environment::lat_long(test_map(), 3.0f, 0.0f);
  EXPECT_FLOAT_EQ(bright.radiance(sun_local).x, 1500.0f);
}

TEST(Environment, ConstantIsUniform) {
  const Environment e = Environment::constant(glm::vec3(0.5f, 1.0f, 2.0f));
  glm::vec3 wi, radiance;
  float pdf;
  ASSERT_TRUE(e.sample(glm::vec2(0.3f, 0.8f), &wi, &pdf, &radiance));
  EXPECT_FLOAT_EQ(pdf, static_cast<float>(1.0 / (4.0 * kPi)));
  EXPECT_EQ(radiance, glm::vec3(0.5f, 1.0f, 2.0f));
  EXPECT_EQ(e.radiance(glm::vec3(0, -1, 0)), glm::vec3(0.5f, 1.0f, 2.0f));
}

class EnvironmentFile : public testing::ScratchDirTest {};

std::string error_of(const std::string& path, std::uint64_t max_pixels = 1 << 20) {
  try {
    load_environment(path, 1.0f, 0.0f, true, max_pixels);
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    return what;
  }
  return "";
}

TEST_F(EnvironmentFile, BadFilesAreRefusedInOneLine) {
  EXPECT_NE(error_of(path("missing.exr")), "");

  std::ofstream(path("corrupt.exr")) << "not an image at all";
  EXPECT_NE(error_of(path("corrupt.exr")), "");

  image::write_image(path("square.exr"), image::Image(16, 16, 3, 1.0f));
  EXPECT_NE(error_of(path("square.exr")).find("not a 2:1"), std::string::npos);

  image::Image nan(16, 8, 3, 1.0f);
  nan.at(5, 3, 1) = std::nanf("");
  image::write_image(path("nan.exr"), nan);
  EXPECT_NE(error_of(path("nan.exr")).find("(5, 3)"), std::string::npos);

  image::Image inf(16, 8, 3, 1.0f);
  inf.at(0, 7, 2) = INFINITY;
  image::write_image(path("inf.exr"), inf);
  EXPECT_NE(error_of(path("inf.exr")).find("(0, 7)"), std::string::npos);

  image::write_image(path("big.exr"), image::Image(64, 32, 3, 1.0f));
  EXPECT_NE(error_of(path("big.exr"), 1000).find("--max-texture-pixels"), std::string::npos);
  EXPECT_EQ(error_of(path("big.exr"), 2048), "");
}

TEST_F(EnvironmentFile, NegativeTexelsAreClampedWithAWarning) {
  image::Image m(16, 8, 3, 1.0f);
  m.at(2, 2, 0) = -0.5f;
  m.at(3, 2, 0) = -1e-6f;
  image::write_image(path("negative.exr"), m);
  std::vector<std::string> warnings;
  const Environment e = load_environment(path("negative.exr"), 1.0f, 0.0f, true, 1 << 20,
                                         &warnings);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("2 negative values clamped"), std::string::npos) << warnings[0];
  EXPECT_GT(e.mean_radiance().x, 0.9f);
}

// The shipped map, written by scenes/generate_env.py (Radiance .hdr): its sun is where the script
// put it, 40 degrees from -Z towards +X and 35 degrees up, so reader and layout agree.
TEST(Environment, ShippedHdrMapHasItsSunWhereTheGeneratorPutIt) {
  const Environment e =
      load_environment(std::string(DOFCACHE_SOURCE_DIR) + "/scenes/env/afternoon_sky.hdr", 1.0f,
                       0.0f, true, 1 << 20);
  EXPECT_EQ(e.width(), 256);
  EXPECT_EQ(e.height(), 128);
  const double el = 35.0 * kPi / 180.0, az = 40.0 * kPi / 180.0;
  const glm::vec3 sun(static_cast<float>(std::cos(el) * std::sin(az)),
                      static_cast<float>(std::sin(el)),
                      static_cast<float>(-std::cos(el) * std::cos(az)));
  EXPECT_GT(e.radiance(sun).x, 1000.0f);
  EXPECT_LT(e.radiance(glm::vec3(-sun.x, sun.y, sun.z)).x, 10.0f);  // not mirrored
  EXPECT_LT(e.radiance(glm::vec3(0, -1, 0)).x, 0.5f);               // the ground
}

scene::Scene one_quad(bool emissive, bool punctual) {
  scene::Scene s;
  s.materials = {testing::diffuse_material(glm::vec3(0.5f)),
                 testing::emissive_material(glm::vec3(1.0f))};
  testing::add_quad_z(s, -1, 1, -1, 1, 0.0f, emissive ? 1 : 0, 0);
  testing::build_emitters(s);
  if (punctual) s.lights.push_back(scene::PunctualLight{});
  return s;
}

TEST(Environment, DefaultSkyExactlyWhenTheSceneHasNoLight) {
  const scene::LoadLimits limits;
  EnvironmentSettings settings;
  const ResolvedEnvironment dark = resolve_environment(settings, one_quad(false, false), limits);
  ASSERT_TRUE(dark.environment);
  EXPECT_TRUE(dark.default_sky);
  // White-ish, about as bright as a viewer's neutral light: mean luminance in [0.5, 1].
  const float y = scene::luminance(dark.environment->mean_radiance());
  EXPECT_GT(y, 0.5f);
  EXPECT_LT(y, 1.0f);
  EXPECT_GT(dark.environment->radiance(glm::vec3(0, 1, 0)).z,
            dark.environment->radiance(glm::vec3(0, -1, 0)).z);

  EXPECT_FALSE(resolve_environment(settings, one_quad(true, false), limits).environment);
  EXPECT_FALSE(resolve_environment(settings, one_quad(false, true), limits).environment);
  settings.default_sky = false;
  EXPECT_FALSE(resolve_environment(settings, one_quad(false, false), limits).environment);
  // A black constant colour is no light either (the documented way to keep a scene dark).
  settings.default_sky = true;
  settings.color = glm::vec3(0.0f);
  const ResolvedEnvironment black = resolve_environment(settings, one_quad(false, false), limits);
  EXPECT_FALSE(black.environment);
  EXPECT_FALSE(black.default_sky);
  // An explicit environment is used with or without other lights.
  settings.color = glm::vec3(0.2f);
  EXPECT_TRUE(resolve_environment(settings, one_quad(true, true), limits).environment);
  settings.path = "x.exr";
  EXPECT_THROW(resolve_environment(settings, one_quad(true, true), limits), Error);
}

}  // namespace
}  // namespace dofcache::render
