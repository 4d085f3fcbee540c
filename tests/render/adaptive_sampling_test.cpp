// Adaptive lens sampling: the allocation (budget kept, noisy pixels favoured, caps and masks
// respected) and a render that reaches a lower error than uniform sampling for the same number of
// lens rays, without moving its mean.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <numeric>
#include <string>
#include <vector>

#include "dofcache/cache/radiance_cache.h"
#include "dofcache/core/error.h"
#include "dofcache/image/metrics.h"
#include "dofcache/render/adaptive_sampling.h"
#include "dofcache/render/renderer.h"
#include "dofcache/render/setup.h"
#include "dofcache/scene/accel.h"
#include "dofcache/scene/gltf_loader.h"

namespace dofcache::render {
namespace {

AdaptiveSampling enabled() {
  AdaptiveSampling a;
  a.enabled = true;
  return a;
}

// A pilot of `count` samples per pixel whose values are mean +- sd (half each).
PixelMoments moments(double mean, double sd, std::uint32_t count) {
  PixelMoments m;
  for (std::uint32_t k = 0; k < count; ++k) {
    const double v = mean + (k % 2 ? sd : -sd);
    m.sum += v, m.sum2 += v * v, ++m.count;
  }
  return m;
}

// A 16x16 pilot of 8 samples per pixel, quiet (standard deviation `quiet`) but for a 3x3 block
// around (7, 7) with standard deviation 0.4.
std::vector<PixelMoments> quiet_with_noisy_block(double quiet) {
  std::vector<PixelMoments> pilot(16 * 16, moments(0.5, quiet, 8));
  for (int y = 6; y < 9; ++y)
    for (int x = 6; x < 9; ++x) pilot[y * 16 + x] = moments(0.5, 0.4, 8);
  return pilot;
}

std::uint64_t total(const std::vector<std::uint32_t>& n) {
  return std::accumulate(n.begin(), n.end(), std::uint64_t{0});
}

TEST(AdaptiveSampling, PilotIsAPowerOfTwoAndLeavesRoom) {
  const AdaptiveSampling a = enabled();
  EXPECT_EQ(pilot_samples(a, 3), 0u);   // too few to measure a variance and keep some back
  EXPECT_EQ(pilot_samples(a, 4), 2u);   // below twice the minimum pilot: half the samples
  EXPECT_EQ(pilot_samples(a, 8), 4u);
  EXPECT_EQ(pilot_samples(a, 15), 4u);  // half is 7, rounded down to 4
  EXPECT_EQ(pilot_samples(a, 16), 8u);  // a quarter is 4, the minimum pilot 8
  EXPECT_EQ(pilot_samples(a, 64), 16u);
  EXPECT_EQ(pilot_samples(a, 100), 16u);  // a quarter is 25, rounded down to 16
  EXPECT_EQ(pilot_samples(a, 128), 32u);
  EXPECT_EQ(pilot_samples(AdaptiveSampling{}, 128), 0u);  // disabled
  AdaptiveSampling whole = enabled();
  whole.pilot_fraction = 1.0f;
  EXPECT_EQ(pilot_samples(whole, 64), 0u);  // the pilot would be everything
}

TEST(AdaptiveSampling, EqualNoiseGivesEverySampleCountEqually) {
  const int w = 10, h = 8, spp = 32;
  std::vector<PixelMoments> pilot(w * h, moments(0.5, 0.1, 8));
  std::vector<char> rendered(w * h, 1);
  const std::vector<std::uint32_t> n = allocate_samples(pilot, rendered, w, h, spp, enabled(), 3);
  for (std::uint32_t v : n) EXPECT_EQ(v, 32u);
}

TEST(AdaptiveSampling, NoisyPixelsGetMoreAndTheBudgetIsKept) {
  const int w = 16, h = 16, spp = 32;
  const AdaptiveSampling a = enabled();
  const std::vector<std::uint32_t> n = allocate_samples(
      quiet_with_noisy_block(0.02), std::vector<char>(w * h, 1), w, h, spp, a, 5);
  const double budget = double(spp) * w * h;
  EXPECT_NEAR(double(total(n)), budget, 0.01 * budget);
  for (std::uint32_t v : n) {
    EXPECT_GE(v, 8u);                                       // the pilot stays
    EXPECT_LE(v, static_cast<std::uint32_t>(a.max_factor * spp) + 1);  // the cap
  }
  EXPECT_GT(n[7 * w + 7], 4u * n[0]);  // the noisy centre against a quiet corner
}

TEST(AdaptiveSampling, TheCapHoldsAndTheRestGoesElsewhere) {
  // 400 times the quiet pixels' deviation would want far more than 8x the mean: the centre gets
  // the cap, and the budget it cannot take goes to the others.
  const int w = 16, h = 16, spp = 32;
  const AdaptiveSampling a = enabled();
  const std::vector<std::uint32_t> n = allocate_samples(
      quiet_with_noisy_block(0.001), std::vector<char>(w * h, 1), w, h, spp, a, 5);
  EXPECT_EQ(n[7 * w + 7], static_cast<std::uint32_t>(a.max_factor * spp));
  const double budget = double(spp) * w * h;
  EXPECT_NEAR(double(total(n)), budget, 0.01 * budget);
}

TEST(AdaptiveSampling, MaskedPixelsTakeNothing) {
  const int w = 8, h = 8, spp = 16;
  std::vector<PixelMoments> pilot(w * h, moments(0.5, 0.1, 8));
  std::vector<char> rendered(w * h, 1);
  for (int i = 0; i < w * h / 2; ++i) rendered[i] = 0, pilot[i] = PixelMoments{};
  const std::vector<std::uint32_t> n = allocate_samples(pilot, rendered, w, h, spp, enabled(), 9);
  for (int i = 0; i < w * h; ++i) EXPECT_EQ(n[i], rendered[i] ? 16u : 0u) << i;
}

TEST(AdaptiveSampling, RejectsAbsurdSettings) {
  AdaptiveSampling a = enabled();
  a.max_factor = 0.5f;
  EXPECT_THROW(a.validate(), Error);
  a = enabled();
  a.pilot_fraction = 0.0f;
  EXPECT_THROW(a.validate(), Error);
  RenderSettings s;
  s.mode = Mode::Accumulation;
  s.adaptive = enabled();
  EXPECT_THROW(s.validate(), Error);
}

// The Cornell box at f/0.7 with the cache, where the noise left is the lens's at blurred edges:
// for the same lens rays, adaptive sampling's error against a converged reference is well below
// uniform sampling's, from a few samples per pixel on, and the image's mean does not move.
TEST(AdaptiveSampling, CachedRenderBeatsUniformAtEqualRays) {
  scene::Scene s = scene::load_gltf(std::string(DOFCACHE_SOURCE_DIR) + "/scenes/cornell_box.gltf");
  scene::Accel accel(s);
  const scene::Camera& camera = s.cameras[0];
  RenderSettings base;
  base.width = 80;
  base.height = height_for_width(camera, base.width);
  base.threads = 2;
  base.progress = Progress::Display::Never;
  base.lens = lens::ThinLens{0.1, 0.7, 1.13};
  auto render_with = [&](int spp, bool adaptive, std::uint64_t seed) {
    auto vdb = cache::make_radiance_cache("vdb");
    RenderSettings r = base;
    r.spp = spp;
    r.seed = seed;
    r.cache.cache = vdb.get();
    r.cache.sample_quality = recommended_sample_quality(spp);
    r.adaptive.enabled = adaptive;
    return render(s, accel, camera, r);
  };
  const image::Image reference = render_with(512, false, 11).color;
  auto mean = [](const image::Image& img) {
    double m = 0;
    for (float v : img.data()) m += v;
    return m / static_cast<double>(img.data().size());
  };
  // 8 spp: a pilot of 4 (half the samples); 32 spp: a pilot of 8. At this size a few lens rays
  // that meet the lamp make much of a render's error, so it varies from seed to seed: the errors
  // are summed over three seeds.
  for (int spp : {8, 32}) {
    double e_uniform = 0.0, e_adaptive = 0.0;
    for (std::uint64_t seed : {12, 13, 14}) {
      const RenderOutput uniform = render_with(spp, false, seed);
      const RenderOutput adaptive = render_with(spp, true, seed);
      EXPECT_NEAR(double(adaptive.stats.camera_rays), double(uniform.stats.camera_rays),
                  0.01 * double(uniform.stats.camera_rays));
      ASSERT_EQ(adaptive.samples.width(), base.width);
      e_uniform += image::compare(uniform.color, reference).rel_mse;
      e_adaptive += image::compare(adaptive.color, reference).rel_mse;
      EXPECT_NEAR(mean(adaptive.color), mean(reference), 0.01 * mean(reference)) << spp << " spp";
    }
    EXPECT_LT(e_adaptive, 0.8 * e_uniform)
        << spp << " spp: uniform " << e_uniform << ", adaptive " << e_adaptive;
  }
}

}  // namespace
}  // namespace dofcache::render
