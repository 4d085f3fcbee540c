// The in-focus cost ratio (render/focus_cost.h) against hand-worked values.
#include <gtest/gtest.h>

#include "dofcache/render/focus_cost.h"

namespace dofcache::render {
namespace {

TEST(FocusCost, SampleGrowthIsOnePlusAFifthPerDoubling) {
  EXPECT_DOUBLE_EQ(focus_sample_growth(2, 2), 1.0);
  EXPECT_DOUBLE_EQ(focus_sample_growth(2, 1), 1.0);   // never shrinks
  EXPECT_DOUBLE_EQ(focus_sample_growth(2, 16), 1.6);  // three doublings
  EXPECT_DOUBLE_EQ(focus_sample_growth(2, 64), 2.0);  // five
  EXPECT_DOUBLE_EQ(focus_sample_growth(0, 64), 1.0);
}

TEST(FocusCost, RatioProjectsTheSamplesRaysPerLookupOverAPerRayShade) {
  FocusCost m;
  m.lookups = 1000, m.samples = 400, m.rays = 40000;
  m.direct_shades = 500, m.direct_rays = 3000;  // 6 rays per per-ray shade
  // At 16 spp: 8000 lookups, 40000 x 1.6 = 64000 sample rays, 8 rays per lookup: 8 / 6.
  EXPECT_NEAR(focus_cost_ratio(m, 2, 16), 8.0 / 6.0, 1e-12);
  // At 64 spp: 32000 lookups, 80000 rays: 2.5 per lookup.
  EXPECT_NEAR(focus_cost_ratio(m, 2, 64), 2.5 / 6.0, 1e-12);
  // Measured at the end: 40 rays per lookup.
  EXPECT_NEAR(focus_cost_ratio(m, 2, 2), 40.0 / 6.0, 1e-12);
}

TEST(FocusCost, NothingMeasuredIsZero) {
  FocusCost m;
  EXPECT_EQ(focus_cost_ratio(m, 2, 16), 0.0);
  m.lookups = 10, m.samples = 5, m.rays = 100;
  EXPECT_EQ(focus_cost_ratio(m, 2, 16), 0.0);  // no per-ray shade measured
  m.direct_shades = 3, m.direct_rays = 12;
  EXPECT_GT(focus_cost_ratio(m, 2, 16), 0.0);
  EXPECT_EQ(focus_cost_ratio(m, 0, 16), 0.0);
  FocusCost sum = m;
  sum += m;
  EXPECT_EQ(sum.lookups, 20u);
  EXPECT_EQ(sum.direct_rays, 24u);
  EXPECT_DOUBLE_EQ(focus_cost_ratio(sum, 2, 16), focus_cost_ratio(m, 2, 16));
}

}  // namespace
}  // namespace dofcache::render
