// The sample radius of eqs. (4.1) and (4.2), with the digest's reading of factor2, the adaptive
// widening and the persistent cache's reuse rule, against values computed by hand.
#include "dofcache/cache/sample_radius.h"

#include <gtest/gtest.h>

#include <cmath>

#include "dofcache/core/error.h"

namespace dofcache::cache {
namespace {

// F = 50 mm, n = 2, P = 2 m; yfov = 2 atan(1/2) makes the film height V_P, so one pixel at
// depth D spans D / y_res: factor1(D) = D / 500 (eq. 4.1).
lens::LensImaging imaging(double focus = 2.0) {
  lens::LensImaging im;
  im.lens.focal_length = 0.05;
  im.lens.fstop = 2.0;
  im.lens.focus_distance = focus;
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
  // The same radii in pixel footprints: factor2 or min_factor, whichever is larger.
  EXPECT_NEAR(sample_radius_pixels(imaging(), 4.0), 1.5625, 1e-9);
  EXPECT_NEAR(sample_radius_pixels(imaging(), 4.0, 2.0), 2.0, 1e-12);
  EXPECT_NEAR(sample_radius_pixels(imaging(), 1.0), 3.125, 1e-9);
  EXPECT_NEAR(sample_radius_pixels(imaging(), 2.0), 0.5, 1e-12);
}

TEST(SampleRadius, GrowsAwayFromTheFocalPlane) {
  double prev = sample_radius(imaging(), 2.0);
  for (double d = 2.5; d < 50.0; d *= 1.5) {
    double r = sample_radius(imaging(), d);
    EXPECT_GT(r, prev);
    prev = r;
  }
}

TEST(SampleRadius, PaperRuleIgnoresTheSmoothDistance) {
  RadiusOrigin o = new_sample_radius(RadiusSettings{}, imaging(), 4.0, 100.0);
  EXPECT_FLOAT_EQ(o.radius, 0.0125f);  // eq. 4.2, as above
  EXPECT_FLOAT_EQ(o.view_radius, 0.0125f);
  EXPECT_FLOAT_EQ(o.footprint, 0.008f);
  EXPECT_FALSE(o.widened());
}

TEST(SampleRadius, AdaptiveRuleWidensToAccuracyTimesTheSmoothDistanceUpToTheCap) {
  RadiusSettings rule;
  rule.rule = RadiusRule::Adaptive;
  rule.accuracy = 0.1;
  rule.max_radius_pixels = 8.0;
  // In focus at 2 m: paper radius 0.002 m, cap 8 x 0.004 = 0.032 m.
  EXPECT_FLOAT_EQ(new_sample_radius(rule, imaging(), 2.0, 0.15).radius, 0.015f);   // 0.1 x 0.15
  EXPECT_FLOAT_EQ(new_sample_radius(rule, imaging(), 2.0, 1.0).radius, 0.032f);    // the cap
  EXPECT_FLOAT_EQ(new_sample_radius(rule, imaging(), 2.0, 0.01).radius, 0.002f);   // the floor
  EXPECT_TRUE(new_sample_radius(rule, imaging(), 2.0, 0.15).widened());
  EXPECT_FALSE(new_sample_radius(rule, imaging(), 2.0, 0.01).widened());
}

TEST(SampleRadius, ReuseRuleShrinksToTheNewCamerasRadiusAndGrowsBackToItsOwn) {
  // Made out of focus at 4 m (focus 2 m): 0.0125 m. Seen in focus at 4 m: half a footprint,
  // 0.004 m. Seen at 4 m with the focus at 1 m: r = 0.5 * 0.025 * 3 / 1 = 0.0375 m > 0.0125,
  // so it grows back only to the radius it was made with.
  RadiusOrigin o = radius_origin(0.0125f, imaging(), 4.0, 0.5);
  EXPECT_FLOAT_EQ(o.view_radius, 0.0125f);
  EXPECT_FLOAT_EQ(reuse_radius(o, 0.0125f, imaging(4.0), 4.0, 0.5), 0.004f);
  EXPECT_FLOAT_EQ(reuse_radius(o, 0.004f, imaging(1.0), 4.0, 0.5), 0.0125f);
  // Not beyond the focal length: the camera cannot see it; the current radius stays.
  EXPECT_FLOAT_EQ(reuse_radius(o, 0.007f, imaging(), 0.04, 0.5), 0.007f);
  EXPECT_FLOAT_EQ(radius_origin(0.01f, imaging(), 0.04, 0.5).view_radius, 0.01f);
}

TEST(SampleRadius, ReuseRuleKeepsAWideningScaledByThePixelFootprint) {
  // Widened to 10x its view radius at 2 m (in focus: 0.002 m), so radius 0.02 m, footprint
  // 0.004 m. Seen in focus at 1 m: footprint 0.002 m, so 0.01 m; at 4 m: not beyond 0.02 m.
  RadiusOrigin o{0.02f, 0.002f, 0.004f};
  ASSERT_TRUE(o.widened());
  EXPECT_FLOAT_EQ(reuse_radius(o, 0.02f, imaging(2.0), 2.0, 0.5), 0.02f);
  EXPECT_NEAR(reuse_radius(o, 0.02f, imaging(1.0), 1.0, 0.5), 0.01f, 1e-7f);
  EXPECT_FLOAT_EQ(reuse_radius(o, 0.02f, imaging(4.0), 4.0, 0.5), 0.02f);
  // Not widened: shrinks to exactly the new frame's radius (in focus at 1 m: 0.001 m).
  RadiusOrigin plain{0.002f, 0.002f, 0.004f};
  EXPECT_NEAR(reuse_radius(plain, 0.002f, imaging(1.0), 1.0, 0.5), 0.001f, 1e-9f);
}

TEST(SampleRadius, RuleNamesAndSettingsAreValidated) {
  EXPECT_EQ(parse_radius_rule("adaptive"), RadiusRule::Adaptive);
  EXPECT_STREQ(radius_rule_name(parse_radius_rule("paper")), "paper");
  EXPECT_THROW(parse_radius_rule("wide"), Error);
  RadiusSettings bad;
  bad.min_factor = std::nan("");
  EXPECT_THROW(bad.validate(), Error);
  bad = RadiusSettings{};
  bad.accuracy = 0.0;
  EXPECT_THROW(bad.validate(), Error);
  EXPECT_NO_THROW(RadiusSettings{}.validate());
}

}  // namespace
}  // namespace dofcache::cache
