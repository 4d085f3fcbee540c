// Pyramid blur (pyramid.h): the variance of reduce-then-expand is V(l) = 0.75 (4^l - 1), blending
// two levels hits the disk variance r^2/4, and constants stay constant.
#include "dofcache/preview/pyramid.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace dofcache::preview {
namespace {

// The pyramid is shift-variant: the kernel depends on where a pixel sits in its 2^l cell (per
// position it is 0.25 px^2 narrower, around a mean that moves by +-0.5 px). V(l) is the variance
// of the kernel averaged over those positions, which is what these moments accumulate.
struct Moments {
  double m0 = 0, m1 = 0, m2 = 0;
  void add(const image::Image& response, double centre) {
    for (int y = 0; y < response.height(); ++y)
      for (int x = 0; x < response.width(); ++x) {
        double v = response.at(x, y, 0), d = x - centre;
        m0 += v;
        m1 += v * d;
        m2 += v * d * d;
      }
  }
  double variance() const { return m2 / m0 - (m1 / m0) * (m1 / m0); }
};

image::Image impulse(int size, int x) {
  image::Image img(size, size, 1, 0.0f);
  img.at(x, size / 2, 0) = 1.0f;
  return img;
}

TEST(Pyramid, LevelVarianceMatchesTheFormula) {
  const int size = 256;
  for (int level = 1; level <= 4; ++level) {
    Moments all;
    const int cell = 1 << level;
    for (int ox = 0; ox < cell; ++ox) {
      std::vector<image::Image> levels(level + 1);
      levels[0] = impulse(size, size / 2 + ox);
      for (int l = 0; l < level; ++l) pyramid_reduce(levels[l], levels[l + 1]);
      image::Image up = levels[level];
      for (int l = level; l > 0; --l) {
        image::Image next;
        pyramid_expand(up, levels[l - 1].width(), levels[l - 1].height(), next);
        up = std::move(next);
      }
      Moments one;
      one.add(up, size / 2 + ox);
      EXPECT_NEAR(one.m0, 1.0, 1e-4) << "level " << level;  // energy is preserved
      all.add(up, size / 2 + ox);
    }
    EXPECT_NEAR(all.variance(), pyramid_level_variance(level), 1e-3 * pyramid_level_variance(level))
        << "level " << level;
  }
}

TEST(Pyramid, BlendedBlurHasTheDiskVariance) {
  const int size = 192;
  for (double r : {1.0, 2.0, 4.5, 9.0, 17.0}) {
    Moments all;
    for (int ox = 0; ox < 32; ++ox)
      all.add(pyramid_blur(impulse(size, size / 2 + ox), r), size / 2 + ox);
    EXPECT_NEAR(all.variance(), 0.25 * r * r, 1e-3 * 0.25 * r * r) << "radius " << r;
  }
}

TEST(Pyramid, LevelChoice) {
  EXPECT_EQ(level_blend_for_radius(0.4, 8, true).level, 0);
  EXPECT_EQ(level_blend_for_radius(0.4, 8, true).t, 0.0f);
  LevelBlend b = level_blend_for_radius(3.0, 8, true);  // exactly level 1
  EXPECT_EQ(b.level + (b.t > 0.5f ? 1 : 0), 1);
  // Kraus & Strengert rounding: the next level up.
  EXPECT_EQ(level_blend_for_radius(3.5, 8, false).level, 2);
  EXPECT_EQ(level_blend_for_radius(3.5, 8, false).t, 0.0f);
  // The top level is a cap.
  EXPECT_EQ(level_blend_for_radius(1e6, 5, true).level, 5);
}

TEST(Pyramid, ConstantStaysConstant) {
  image::Image img(37, 23, 4, 0.3f);
  for (double r : {0.7, 2.5, 6.0, 30.0}) {
    image::Image b = pyramid_blur(img, r);
    for (float v : b.data()) ASSERT_NEAR(v, 0.3f, 1e-6f) << r;
  }
}

}  // namespace
}  // namespace dofcache::preview

namespace dofcache::preview {
namespace {

// The small-radius kernel: its 1-D taps are the disk's marginal integrated over each pixel, so
// they sum to one, are symmetric, reach ceil(r - 1/2) pixels, and have the disk's variance r^2/4
// plus about the 1/12 of integrating over a pixel.
TEST(DiskProfile, TapsAreTheDiskMarginal) {
  EXPECT_EQ(disk_profile_taps(0.4).size(), 1u);
  for (double r : {0.75, 1.5, 2.13, 3.0, 4.5, 6.6}) {
    std::vector<float> t = disk_profile_taps(r);
    const int R = static_cast<int>(t.size() / 2);
    EXPECT_EQ(R, static_cast<int>(std::ceil(r - 0.5))) << r;
    double sum = 0, var = 0;
    for (int k = -R; k <= R; ++k) {
      sum += t[k + R];
      var += t[k + R] * k * k;
      EXPECT_FLOAT_EQ(t[k + R], t[R - k]);
      EXPECT_GT(t[k + R], 0.0f);
    }
    EXPECT_NEAR(sum, 1.0, 1e-6) << r;
    EXPECT_GT(var, r * r / 4 - 0.01) << r;
    EXPECT_LT(var, r * r / 4 + 1.0 / 12 + 0.05) << r;
  }
}

// A vertical step edge blurred with the disk-profile kernel gives at each pixel the fraction of
// the disk around the pixel's centre that lies beyond the edge (for a scene constant over each
// pixel, as the anti-aliased pinhole image is), as a lens does; the pyramid blend of levels 0 and
// 1 for the same radius keeps 3/4 of the weight on the pixel itself.
TEST(DiskProfile, StepEdgeFollowsTheDisk) {
  const double r = 2.0;
  const int w = 32, h = 8, edge = 16;  // pixels x >= edge are 1
  image::Image step(w, h, 1, 0.0f);
  for (int y = 0; y < h; ++y)
    for (int x = edge; x < w; ++x) step.at(x, y, 0) = 1.0f;
  image::Image direct = disk_profile_blur(step, r);
  image::Image pyramid = pyramid_blur(step, r);
  double err_direct = 0, err_pyramid = 0;
  for (int x = edge - 4; x < edge + 4; ++x) {
    const double c = std::clamp((edge - (x + 0.5)) / r, -1.0, 1.0);  // the edge from the centre
    const double frac = 1.0 - (c * std::sqrt(1 - c * c) + std::asin(c) + M_PI / 2) / M_PI;
    err_direct = std::max(err_direct, std::abs(direct.at(x, h / 2, 0) - frac));
    err_pyramid = std::max(err_pyramid, std::abs(pyramid.at(x, h / 2, 0) - frac));
  }
  EXPECT_LT(err_direct, 0.01);
  EXPECT_GT(err_pyramid, 0.1);  // the spike-and-halo kernel the direct blur replaces
}

}  // namespace
}  // namespace dofcache::preview
