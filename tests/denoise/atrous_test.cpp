// The guided a-trous filter against what it must do by construction: leave noise-free images
// alone, keep texture (the albedo is divided out and put back), never mix objects, leave pixels
// that see nothing, keep the mean of a noisy surface and cut its noise.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "dofcache/core/error.h"
#include "dofcache/core/rng.h"
#include "dofcache/denoise/atrous.h"

using namespace dofcache;
using image::Image;

namespace {

constexpr int kW = 48, kH = 32;

// A plane facing the camera at depth 2 (ids 0), its albedo 0.5 unless given.
struct Scene {
  Image color{kW, kH, 3, 0.0f}, albedo{kW, kH, 3, 0.5f}, normal{kW, kH, 3, 0.0f},
      depth{kW, kH, 1, 2.0f}, ids{kW, kH, 1, 0.0f};
  Scene() {
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) normal.pixel(x, y)[2] = 1.0f;
  }
  denoise::Guides guides() const { return {&albedo, &normal, &depth, &ids}; }
};

double mean_red(const Image& img, int x0, int x1) {
  double s = 0;
  for (int y = 0; y < kH; ++y)
    for (int x = x0; x < x1; ++x) s += img.at(x, y, 0);
  return s / ((x1 - x0) * kH);
}

TEST(Atrous, NoiseFreeImagesAndTexturesStayAsTheyAre) {
  Scene s;
  // A checker albedo under constant irradiance 2: colour = 2 * albedo, texture everywhere.
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      const float a = ((x / 3 + y / 3) % 2) ? 0.8f : 0.1f;
      for (int c = 0; c < 3; ++c) {
        s.albedo.pixel(x, y)[c] = a;
        s.color.pixel(x, y)[c] = 2.0f * a;
      }
    }
  const Image out = denoise::atrous_filter(s.color, s.guides());
  for (std::size_t i = 0; i < out.data().size(); ++i)
    EXPECT_NEAR(out.data()[i], s.color.data()[i], 1e-5f) << i;
}

TEST(Atrous, ObjectsAreNotMixedAndPixelsThatSeeNothingAreKept) {
  Scene s;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      const bool right = x >= kW / 2;
      s.ids.at(x, y, 0) = right ? 1.0f : 0.0f;
      for (int c = 0; c < 3; ++c) s.color.pixel(x, y)[c] = right ? 3.0f : 1.0f;
      if (y == 0) {  // the top row sees nothing: the background, noisy
        s.depth.at(x, y, 0) = std::numeric_limits<float>::infinity();
        s.ids.at(x, y, 0) = -1.0f;
        s.color.pixel(x, y)[0] = float(x % 5);
      }
    }
  const Image out = denoise::atrous_filter(s.color, s.guides());
  for (int y = 1; y < kH; ++y)
    for (int x = 0; x < kW; ++x)
      EXPECT_NEAR(out.at(x, y, 0), x >= kW / 2 ? 3.0f : 1.0f, 1e-5f) << x << "," << y;
  for (int x = 0; x < kW; ++x) EXPECT_EQ(out.at(x, 0, 0), float(x % 5));
}

TEST(Atrous, NoiseFallsAndTheMeanStays) {
  Scene s;
  Rng rng(5, 1);
  // Irradiance 1 with noise of standard deviation 0.5 (uniform), albedo 0.5: colour 0.5 +- 0.25.
  double in_var = 0;
  for (std::size_t i = 0; i < s.color.pixel_count(); ++i) {
    const float v = 0.5f * (1.0f + (rng.uniform() - 0.5f) * std::sqrt(12.0f) * 0.5f);
    for (int c = 0; c < 3; ++c) s.color.data()[i * 3 + c] = v;
    in_var += (v - 0.5) * (v - 0.5);
  }
  in_var /= s.color.pixel_count();
  const Image out = denoise::atrous_filter(s.color, s.guides());
  double out_var = 0;
  for (std::size_t i = 0; i < out.pixel_count(); ++i)
    out_var += (out.data()[i * 3] - 0.5) * (out.data()[i * 3] - 0.5);
  out_var /= out.pixel_count();
  EXPECT_NEAR(mean_red(out, 0, kW), mean_red(s.color, 0, kW), 0.01 * 0.5);
  EXPECT_LT(out_var, in_var / 10.0) << "input variance " << in_var << ", output " << out_var;
}

TEST(Atrous, GuidesOfAnotherSizeAreRefused) {
  Scene s;
  Image small(8, 8, 3, 0.0f);
  EXPECT_THROW(denoise::atrous_filter(s.color, {&small, &s.normal, &s.depth, &s.ids}), Error);
  EXPECT_THROW(denoise::atrous_filter(s.color, {&s.albedo, &s.normal, nullptr, &s.ids}), Error);
}

}  // namespace
