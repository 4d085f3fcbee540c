// The lens-aware filter of a render against what it must do by construction: cut the measured
// noise of a surface and keep its mean, never cross an in-focus edge, never sharpen a defocused
// one (whose centre-ray ids step where the colour ramps), leave emission and pixels that see
// nothing as rendered, keep a firefly from spreading, pull in a spot its measured noise misses
// (a shared cache sample) but not a shadow edge; and the circle of confusion against hand-computed
// values.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "dofcache/core/error.h"
#include "dofcache/core/rng.h"
#include "dofcache/denoise/render_filter.h"

using namespace dofcache;
using image::Image;

namespace {

constexpr int kW = 64, kH = 32;

// A render of a plane facing the camera at depth 2 (id 0, albedo 0.5, fully covered, in focus),
// its colour and measured noise to be filled by each test.
struct Render {
  Image color{kW, kH, 3, 0.0f}, albedo{kW, kH, 3, 0.5f}, normal{kW, kH, 3, 0.0f},
      coverage{kW, kH, 1, 1.0f}, emission{kW, kH, 3, 0.0f}, emission_variance{kW, kH, 1, 0.0f},
      variance{kW, kH, 1, 0.0f},
      depth{kW, kH, 1, 2.0f}, ids{kW, kH, 1, 0.0f}, coc{kW, kH, 1, 0.0f};
  Render() {
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) normal.pixel(x, y)[2] = 1.0f;
  }
  denoise::RenderGuides guides() const {
    return {&albedo, &albedo, &normal, &coverage, &emission, &emission, &emission_variance,
            &variance, &depth, &ids, &coc};
  }
  // Grey colour `truth(x)` plus noise of standard deviation sd (the same on every channel, so
  // the luminance's), whose variance the render measured.
  template <class Truth>
  void fill(Truth truth, float sd, std::uint64_t seed) {
    Rng rng(seed, 0);
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) {
        // A sum of uniforms: mean 0, variance sd^2.
        float n = 0.0f;
        for (int k = 0; k < 12; ++k) n += rng.uniform();
        const float v = truth(x) + sd * (n - 6.0f);
        for (int c = 0; c < 3; ++c) color.pixel(x, y)[c] = v;
        variance.at(x, y, 0) = sd * sd;
      }
  }
};

double column_mean(const Image& img, int x) {
  double s = 0;
  for (int y = 0; y < kH; ++y) s += img.at(x, y, 0);
  return s / kH;
}

double mse(const Image& img, double truth) {
  double s = 0;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) s += (img.at(x, y, 0) - truth) * (img.at(x, y, 0) - truth);
  return s / (kW * kH);
}

TEST(RenderFilter, ANoisySurfaceLosesItsNoiseAndKeepsItsMean) {
  Render r;
  r.fill([](int) { return 1.0f; }, 0.2f, 1);
  const Image out = denoise::render_filter(r.color, r.guides());
  EXPECT_LT(mse(out, 1.0), mse(r.color, 1.0) / 20.0);
  double mean = 0;
  for (int x = 0; x < kW; ++x) mean += column_mean(out, x) / kW;
  EXPECT_NEAR(mean, 1.0, 0.01);
}

TEST(RenderFilter, AnInFocusEdgeIsNotCrossed) {
  Render r;
  // Two objects side by side at the same depth; the step (0.5) is 2.5 noise deviations only,
  // so the colour alone would not keep them apart: the in-focus ids must.
  r.fill([](int x) { return x < kW / 2 ? 1.0f : 1.5f; }, 0.2f, 2);
  for (int y = 0; y < kH; ++y)
    for (int x = kW / 2; x < kW; ++x) r.ids.at(x, y, 0) = 1.0f;
  const Image out = denoise::render_filter(r.color, r.guides());
  // A column mean of 32 filtered pixels: noise well under 0.05; a crossing would move the
  // columns next to the edge by a good part of the step.
  EXPECT_NEAR(column_mean(out, kW / 2 - 1), 1.0, 0.05);
  EXPECT_NEAR(column_mean(out, kW / 2), 1.5, 0.05);
}

TEST(RenderFilter, ADefocusedEdgeIsNotSharpened) {
  Render r;
  // A defocused edge: the colour ramps from 1 to 3 over 20 pixels, while the centre rays' ids
  // and depths step in the middle (sharp where the colour is not). Circles of 10 pixels.
  auto ramp = [](int x) { return 1.0f + 2.0f * std::clamp((x - 22) / 20.0f, 0.0f, 1.0f); };
  r.fill(ramp, 0.1f, 3);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      r.coc.at(x, y, 0) = 10.0f;
      if (x >= kW / 2) r.ids.at(x, y, 0) = 1.0f, r.depth.at(x, y, 0) = 4.0f;
    }
  const Image out = denoise::render_filter(r.color, r.guides());
  for (int x = 16; x < 48; ++x) EXPECT_NEAR(column_mean(out, x), ramp(x), 0.06) << x;
  // The same render taken as in focus keeps the two sides apart, each filtered on its own: the
  // ramp breaks at the middle. This is what the circles of confusion prevent.
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) r.coc.at(x, y, 0) = 0.0f;
  const Image sharp = denoise::render_filter(r.color, r.guides());
  const double step = column_mean(sharp, kW / 2) - column_mean(sharp, kW / 2 - 1);
  EXPECT_GT(step, 2.0 * (ramp(kW / 2) - ramp(kW / 2 - 1)));
}

TEST(RenderFilter, EmissionAndPixelsThatSeeNothingStayAsRendered) {
  Render r;
  r.fill([](int) { return 1.0f; }, 0.2f, 4);
  Rng rng(5, 0);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW / 4; ++x) {  // a lamp's noisy edge: colour all emission
      const float e = 20.0f * rng.uniform();
      for (int c = 0; c < 3; ++c) r.color.pixel(x, y)[c] = r.emission.pixel(x, y)[c] = e;
      r.albedo.pixel(x, y)[0] = r.albedo.pixel(x, y)[1] = r.albedo.pixel(x, y)[2] = 0.0f;
      r.variance.at(x, y, 0) = 0.0f;  // nothing reflected: no noise left to filter
    }
  for (int y = 0; y < kH; ++y)
    for (int x = kW - 4; x < kW; ++x) {  // the sky
      r.coverage.at(x, y, 0) = 0.0f;
      r.depth.at(x, y, 0) = std::numeric_limits<float>::infinity();
      for (int c = 0; c < 3; ++c) r.color.pixel(x, y)[c] = 7.0f + x;
    }
  const Image out = denoise::render_filter(r.color, r.guides());
  for (int y = 0; y < kH; ++y) {
    // Filtered, the lamp's pixels would move by several units; they move by what the albedo
    // floor lets in of their neighbours' light (a few thousandths).
    for (int x = 0; x < kW / 4; ++x) EXPECT_NEAR(out.at(x, y, 1), r.color.at(x, y, 1), 0.01f);
    for (int x = kW - 4; x < kW; ++x) EXPECT_EQ(out.at(x, y, 1), 7.0f + x);
  }
  EXPECT_LT(mse(out, 1.0), mse(r.color, 1.0));  // the rest was filtered
}

TEST(RenderFilter, AFireflyDoesNotSpread) {
  Render r;
  r.fill([](int) { return 1.0f; }, 0.05f, 6);
  // One sample of 16 met a caustic of 800: the pixel's mean is 50, its measured variance of the
  // mean 800^2 / 16 / 15 (about 2700).
  const int fx = 30, fy = 15;
  for (int c = 0; c < 3; ++c) r.color.pixel(fx, fy)[c] = 50.0f;
  r.variance.at(fx, fy, 0) = 800.0f * 800.0f / 16.0f / 15.0f;
  const Image out = denoise::render_filter(r.color, r.guides());
  for (int dy = -3; dy <= 3; ++dy)
    for (int dx = -3; dx <= 3; ++dx)
      if (dx || dy) {
        EXPECT_LT(out.at(fx + dx, fy + dy, 0), 1.3f) << dx << "," << dy;
      }
  EXPECT_LT(out.at(fx, fy, 0), 5.0f);
}

TEST(RenderFilter, ASpotTheNoiseMissesJoinsItsSurroundingsButAShadowEdgeStays) {
  Render r;
  // A shadow edge on one object (a step of 1 to 3 at x = 32, as sharp as the film) and a bright
  // cached spot in the shadow, one pixel whose lens samples all read one cache sample: its
  // measured noise is as small as everyone's.
  r.fill([](int x) { return x < kW / 2 ? 1.0f : 3.0f; }, 0.02f, 8);
  const int sx = 10, sy = 15;
  for (int c = 0; c < 3; ++c) r.color.pixel(sx, sy)[c] = 20.0f;
  const Image out = denoise::render_filter(r.color, r.guides());
  EXPECT_LT(out.at(sx, sy, 0), 2.0f);
  for (int dy = -2; dy <= 2; ++dy)
    for (int dx = -2; dx <= 2; ++dx)
      if (dx || dy) {
        EXPECT_LT(out.at(sx + dx, sy + dy, 0), 1.2f) << dx << "," << dy;
      }
  EXPECT_NEAR(column_mean(out, kW / 2 - 1), 1.0, 0.02);
  EXPECT_NEAR(column_mean(out, kW / 2), 3.0, 0.02);
}

TEST(RenderFilter, BadGuidesAreRefused) {
  Render r;
  denoise::RenderGuides g = r.guides();
  g.variance = nullptr;
  EXPECT_THROW(denoise::render_filter(r.color, g), Error);
  const Image small(8, 8, 3, 0.0f);
  g = r.guides();
  g.albedo = &small;
  EXPECT_THROW(denoise::render_filter(r.color, g), Error);
  denoise::RenderFilterOptions o;
  o.iterations = 11;
  EXPECT_THROW(denoise::render_filter(r.color, r.guides(), o), Error);
}

TEST(RenderFilter, CircleOfConfusionIsTheLargerOfTheCentreAndTheLensDepths) {
  // 50 mm f/2 focused at 2 m, yfov 0.8, 480 rows. By eq. (2.4), C = |V_D - V_P| F / (n V_D)
  // with V = D F / (D - F), over a pixel pitch of 2 V_P tan(yfov / 2) / 480: at 4 m a radius of
  // 1.77392 pixels, at 1 m 3.54783.
  lens::LensImaging imaging;
  imaging.lens.focal_length = 0.05;
  imaging.lens.fstop = 2.0;
  imaging.lens.focus_distance = 2.0;
  imaging.yfov = 0.8;
  imaging.y_resolution = 480;
  const float inf = std::numeric_limits<float>::infinity();
  Image centre(3, 1, 1, 4.0f), lens_depth(3, 1, 1, 1.0f);
  lens_depth.at(1, 0, 0) = inf;           // no lens sample hit: the centre's alone
  centre.at(2, 0, 0) = inf, lens_depth.at(2, 0, 0) = inf;  // nothing
  const Image coc = denoise::coc_radius_image(centre, lens_depth, imaging);
  EXPECT_NEAR(coc.at(0, 0, 0), 3.54783, 1e-3);
  EXPECT_NEAR(coc.at(1, 0, 0), 1.77392, 1e-3);
  EXPECT_EQ(coc.at(2, 0, 0), 0.0f);
  EXPECT_THROW(denoise::coc_radius_image(centre, Image(3, 1, 3, 1.0f), imaging), Error);
}

}  // namespace
