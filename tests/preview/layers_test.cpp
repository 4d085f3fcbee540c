// Layer planning and matting (layers.h): the CoC map, the layer rule, and the partition of unity
// of the composited mattes.
#include "dofcache/preview/layers.h"
#include "dofcache/preview/synthetic_scene.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace dofcache::preview {
namespace {

lens::LensImaging test_imaging() { return demo_imaging(480); }

TEST(CocMap, MatchesTheThinLensInPixels) {
  lens::LensImaging im = test_imaging();
  CocMap coc(im, 1000.0);
  for (double d : {0.5, 0.9, 1.7, 3.0, 4.2, 9.0, 100.0})
    EXPECT_NEAR(coc(d), im.signed_coc_pixels(d), 1e-4 * (1 + std::abs(im.signed_coc_pixels(d))))
        << d;
  // The background has the limit value, which depth_for_signed_coc maps back to infinity.
  EXPECT_NEAR(coc(std::numeric_limits<double>::infinity()), coc.k(), 1e-4);
  EXPECT_TRUE(std::isinf(im.depth_for_signed_coc(coc.k())));
  // Clamping.
  CocMap clamped(im, 4.0);
  EXPECT_FLOAT_EQ(clamped(0.3), -8.0f);
}

TEST(LayerPlan, EvenlySpacedOverThePresentRangeOnly) {
  lens::LensImaging im = test_imaging();
  PreviewOptions o;
  LayerPlan plan = plan_layers_for_range(-20.0, 6.0, im, o);
  ASSERT_GE(plan.size(), 2);
  // Covers the range, at most one step beyond it at either end.
  EXPECT_LE(plan.layers.front().signed_coc, -20.0);
  EXPECT_GT(plan.layers.front().signed_coc, -20.0 - plan.step);
  EXPECT_GE(plan.layers.back().signed_coc, 6.0);
  EXPECT_LT(plan.layers.back().signed_coc, 6.0 + plan.step);
  bool focus_is_an_anchor = false;
  for (int i = 0; i < plan.size(); ++i) {
    const PreviewLayer& l = plan.layers[i];
    EXPECT_NEAR(l.signed_coc, plan.layers[0].signed_coc + i * plan.step, 1e-9);
    EXPECT_NEAR(l.blur_radius, 0.5 * std::abs(l.signed_coc), 1e-12);
    EXPECT_NEAR(im.signed_coc_pixels(l.depth), l.signed_coc, 1e-6);  // z_i from the CoC
    if (i > 0) {
      EXPECT_GT(l.depth, plan.layers[i - 1].depth);
    }
    focus_is_an_anchor = focus_is_an_anchor || l.signed_coc == 0.0;
  }
  EXPECT_TRUE(focus_is_an_anchor);
}

TEST(LayerPlan, CountRule) {
  lens::LensImaging im = test_imaging();
  PreviewOptions o;
  o.max_layers = 64;
  o.min_layer_step = 1.5;
  // Range through focus: step 1.5 px of radius = 3 px of CoC; anchors -18 .. 12.
  LayerPlan through = plan_layers_for_range(-16.0, 10.0, im, o);
  EXPECT_EQ(through.size(), 11);
  EXPECT_DOUBLE_EQ(through.step, 3.0);
  EXPECT_DOUBLE_EQ(through.layers.front().signed_coc, -18.0);
  // Behind focus only, radii 8..16: half an octave at r = 8 is 3.31 px of radius, 6.63 px of
  // CoC; anchors 2..5 steps.
  LayerPlan behind = plan_layers_for_range(16.0, 32.0, im, o);
  EXPECT_EQ(behind.size(), 4);
  EXPECT_NEAR(behind.step, 2.0 * (std::sqrt(2.0) - 1.0) * 8.0, 1e-9);
  // Flat scene: one layer at its CoC.
  LayerPlan flat = plan_layers_for_range(7.0, 7.0, im, o);
  ASSERT_EQ(flat.size(), 1);
  EXPECT_DOUBLE_EQ(flat.layers[0].blur_radius, 3.5);
  // The cap, and the forced count (end anchors exactly at the range ends).
  o.max_layers = 5;
  EXPECT_LE(plan_layers_for_range(-40.0, 40.0, im, o).size(), 5);
  for (double lo : {-41.0, -17.3, 0.5, 3.0})
    for (double hi : {lo + 0.1, lo + 9.0, lo + 77.0})
      EXPECT_LE(plan_layers_for_range(lo, hi, im, o).size(), 5) << lo << " " << hi;
  o.layer_count = 7;
  LayerPlan forced = plan_layers_for_range(-40.0, 40.0, im, o);
  EXPECT_EQ(forced.size(), 7);
  EXPECT_DOUBLE_EQ(forced.layers.front().signed_coc, -40.0);
  EXPECT_DOUBLE_EQ(forced.layers.back().signed_coc, 40.0);
}

TEST(LayerPlan, FromADepthBuffer) {
  lens::LensImaging im = test_imaging();
  image::Image depth(4, 1, 1);
  depth.at(0, 0, 0) = 1.0f;
  depth.at(1, 0, 0) = 3.0f;
  depth.at(2, 0, 0) = 5.0f;
  depth.at(3, 0, 0) = std::numeric_limits<float>::infinity();
  PreviewOptions o;
  LayerPlan plan = plan_layers(depth, im, o);
  CocMap coc(im, o.max_coc_radius);
  EXPECT_FLOAT_EQ(static_cast<float>(plan.coc_min), coc(1.0));
  EXPECT_FLOAT_EQ(static_cast<float>(plan.coc_max), coc(std::numeric_limits<double>::infinity()));
  EXPECT_LE(plan.layers.front().depth, 1.0 + 1e-9);
  EXPECT_TRUE(std::isinf(plan.layers.back().depth));  // the background's anchor
  EXPECT_FALSE(std::isinf(plan.layers[plan.size() - 2].depth));
}

TEST(Matting, TrapezoidShape) {
  lens::LensImaging im = test_imaging();
  PreviewOptions o;
  o.layer_count = 6;
  LayerPlan plan = plan_layers_for_range(-10.0, 10.0, im, o);  // anchors -10, -6, ..., 10
  const int i = 3;                                             // anchor 2
  EXPECT_FLOAT_EQ(matting_weight(plan, i, -7.0), 0.0f);        // before c_{i-2} = -6
  EXPECT_FLOAT_EQ(matting_weight(plan, i, -4.0), 0.5f);        // rising
  EXPECT_FLOAT_EQ(matting_weight(plan, i, -2.0), 1.0f);        // c_{i-1}
  EXPECT_FLOAT_EQ(matting_weight(plan, i, 0.0), 1.0f);         // plateau
  EXPECT_FLOAT_EQ(matting_weight(plan, i, 2.0), 1.0f);         // c_i
  EXPECT_FLOAT_EQ(matting_weight(plan, i, 3.0), 0.75f);        // falling
  EXPECT_FLOAT_EQ(matting_weight(plan, i, 6.0), 0.0f);         // c_{i+1}
  // End layers keep their plateau.
  EXPECT_FLOAT_EQ(matting_weight(plan, 0, -100.0), 1.0f);
  EXPECT_FLOAT_EQ(matting_weight(plan, 5, 100.0), 1.0f);
  EXPECT_FLOAT_EQ(matting_weight(plan, 5, 4.0), 0.5f);
  // Revealed fragments: hard cut on the front side only.
  EXPECT_FLOAT_EQ(revealed_matting_weight(plan, i, -4.0), 0.0f);
  EXPECT_FLOAT_EQ(revealed_matting_weight(plan, i, -2.0), 1.0f);
  EXPECT_FLOAT_EQ(revealed_matting_weight(plan, i, 3.0), 0.75f);
}

TEST(Matting, CompositedWeightsSumToOneForEveryDepth) {
  lens::LensImaging im = test_imaging();
  for (int layers : {1, 2, 3, 4, 7, 12, 40}) {
    PreviewOptions o;
    o.layer_count = layers;
    LayerPlan plan = plan_layers_for_range(-23.0, 9.5, im, o);
    ASSERT_EQ(plan.size(), layers);
    // Dense sweep over and beyond the present range, and over real depths.
    for (int k = 0; k <= 20000; ++k) {
      double c = -30.0 + 45.0 * k / 20000.0;
      ASSERT_NEAR(composite_coverage(plan, c), 1.0, 1e-6) << layers << " layers, c = " << c;
    }
    for (int k = 1; k <= 5000; ++k) {
      double depth = 0.2 + 0.01 * k;
      double c = CocMap(im, o.max_coc_radius)(depth);
      ASSERT_NEAR(composite_coverage(plan, c), 1.0, 1e-6) << depth;
    }
    // The effective weights are hats on the anchors: at anchor j all weight is on layer j.
    for (int j = 0; j < plan.size(); ++j) {
      double c = plan.layers[j].signed_coc, transmitted = 1.0;
      for (int i = 0; i < plan.size(); ++i) {
        double w = matting_weight(plan, i, c), effective = transmitted * w;
        EXPECT_NEAR(effective, i == j ? 1.0 : 0.0, 1e-5) << "anchor " << j << " layer " << i;
        transmitted *= 1.0 - w;
      }
    }
  }
}

TEST(Matting, HatShapeAndHalves) {
  lens::LensImaging im = test_imaging();
  PreviewOptions o;
  o.layer_count = 6;
  LayerPlan plan = plan_layers_for_range(-10.0, 10.0, im, o);  // anchors -10, -6, ..., 10
  const int i = 3;                                             // anchor 2
  EXPECT_FLOAT_EQ(hat_weight(plan, i, -2.0), 0.0f);            // c_{i-1}
  EXPECT_FLOAT_EQ(hat_weight(plan, i, -1.0), 0.25f);           // rising half
  EXPECT_FLOAT_EQ(hat_weight(plan, i, 2.0), 1.0f);             // c_i, counted once
  EXPECT_FLOAT_EQ(hat_weight(plan, i, 5.0), 0.25f);            // falling half
  EXPECT_FLOAT_EQ(hat_weight(plan, i, 6.0), 0.0f);             // c_{i+1}
  EXPECT_FLOAT_EQ(hat_weight(plan, 0, -100.0), 1.0f);          // end layers keep 1 beyond
  EXPECT_FLOAT_EQ(hat_weight(plan, 5, 100.0), 1.0f);
  EXPECT_FLOAT_EQ(hat_weight(plan, 5, 8.0), 0.5f);
}

TEST(Matting, HatsSumToOneForEveryDepth) {
  lens::LensImaging im = test_imaging();
  for (int layers : {1, 2, 3, 7, 12, 40}) {
    PreviewOptions o;
    o.layer_count = layers;
    LayerPlan plan = plan_layers_for_range(-23.0, 9.5, im, o);
    for (int k = 0; k <= 20000; ++k) {
      const double c = -30.0 + 45.0 * k / 20000.0;
      double sum = 0;
      for (int j = 0; j < plan.size(); ++j) sum += hat_weight(plan, j, c);
      ASSERT_NEAR(sum, 1.0, 1e-5) << layers << " layers, c = " << c;
    }
    for (int j = 0; j < plan.size(); ++j)  // at anchor j all weight is on layer j
      EXPECT_NEAR(hat_weight(plan, j, plan.layers[j].signed_coc), 1.0, 1e-5) << j;
  }
}

}  // namespace
}  // namespace dofcache::preview
