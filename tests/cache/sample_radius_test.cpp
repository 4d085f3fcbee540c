// The sample radius of eqs. (4.1) and (4.2), with the digest's reading of factor2, against values
// computed by hand.
#include "dofcache/cache/sample_radius.h"

#include <gtest/gtest.h>

#include <cmath>

namespace dofcache::cache {
namespace {

// F = 50 mm, n = 2, P = 2 m; yfov = 2 atan(1/2) makes the film height V_P, so one pixel at
// depth D spans D / y_res: factor1(D) = D / 500 (eq. 4.1).
lens::LensImaging imaging() {
  lens::LensImaging im;
  im.lens.focal_length = 0.05;
  im.lens.fstop = 2.0;
  im.lens.focus_distance = 2.0;
  im.yfov = 2.0 * std::atan(0.5);
  im.y_resolution = 500;
  return im;
}

TEST(SampleRadius, Factor1IsThePixelFootprintEq4_1) {
  EXPECT_NEAR(imaging().pixel_footprint(2.0), 0.004, 1e-12);
  EXPECT_NEAR(imaging().pixel_footprint(4.0), 0.008, 1e-12);
}

TEST(SampleRadius, InFocusCoversMinFactorOfAPixel) {
  // D = P: the circle of confusion vanishes, so radius = 0.5 * factor1(2) = 0.002 m.
  EXPECT_NEAR(sample_radius(imaging(), 2.0), 0.002, 1e-12);
  EXPECT_NEAR(sample_radius(imaging(), 2.0, 2.0), 0.008, 1e-12);
  // D = 1.9 m: cone radius (eq. 2.5) r = 0.5 * 0.025 * 0.1 / 2 = 0.000625 m; factor1 = 0.0038 m,
  // so factor2 = 0.000625 / 0.0038 = 0.164 px < 0.5: still min_factor, radius = 0.0019 m.
  EXPECT_NEAR(sample_radius(imaging(), 1.9), 0.0019, 1e-12);
}

TEST(SampleRadius, OutOfFocusCoversTheCircleOfConfusionEq4_2) {
  // D = 4 m: r = 0.5 * 0.025 * 2 / 2 = 0.0125 m; factor1 = 0.008 m; factor2 (CoC radius in
  // pixels) = 0.0125 / 0.008 = 1.5625 px; radius = 0.008 * 1.5625 = 0.0125 m.
  EXPECT_NEAR(imaging().coc_radius_pixels(4.0), 1.5625, 1e-9);
  EXPECT_NEAR(sample_radius(imaging(), 4.0), 0.0125, 1e-12);
  // With min_factor 2 the floor wins: 0.008 * 2 = 0.016 m.
  EXPECT_NEAR(sample_radius(imaging(), 4.0, 2.0), 0.016, 1e-12);
  // D = 1 m (in front): r = 0.5 * 0.025 * 1 / 2 = 0.00625 m; factor1 = 0.002 m; 3.125 px.
  EXPECT_NEAR(sample_radius(imaging(), 1.0), 0.00625, 1e-12);
}

TEST(SampleRadius, GrowsAwayFromTheFocalPlane) {
  double prev = sample_radius(imaging(), 2.0);
  for (double d = 2.5; d < 50.0; d *= 1.5) {
    double r = sample_radius(imaging(), d);
    EXPECT_GT(r, prev);
    prev = r;
  }
}

}  // namespace
}  // namespace dofcache::cache
