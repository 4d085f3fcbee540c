// The occlusion masks (occlusion.h) of a hand-built scene: a front square F over a middle square M
// over the background B, with the near-plane id layers L_0..L_4 written out by hand.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "dofcache/core/error.h"
#include "dofcache/preview/occlusion.h"
#include "dofcache/preview/synthetic_scene.h"

namespace dofcache::preview {
namespace {

constexpr int kSize = 40;
constexpr float kB = 0, kM = 1, kF = 2;  // ids

bool in_square(int x, int y, int lo, int hi) { return x >= lo && x < hi && y >= lo && y < hi; }

class OcclusionMasks : public ::testing::Test {
 protected:
  void SetUp() override {
    imaging = demo_imaging(480);  // k = c(inf) is about 9.3 px ...
    options.max_coc_radius = 4;  // ... clamped to 8: the background's CoC is 8
    options.layer_count = 5;
    plan = plan_layers_for_range(-8.0, 8.0, imaging, options);  // anchors -8, -4, 0, 4, 8
    ASSERT_EQ(plan.size(), 5);
    for (int j = 0; j < 5; ++j) ASSERT_DOUBLE_EQ(plan.layers[j].signed_coc, -8.0 + 4.0 * j);

    // B at infinity (c = 8), M at c = +1 on [4, 36)^2, F at c = -7 on [8, 32)^2.
    const float zM = static_cast<float>(imaging.depth_for_signed_coc(1.0));
    const float zF = static_cast<float>(imaging.depth_for_signed_coc(-7.0));
    depth = image::Image(kSize, kSize, 1, std::numeric_limits<float>::infinity());
    ids.assign(5, image::Image(kSize, kSize, 1, kB));
    for (int y = 0; y < kSize; ++y)
      for (int x = 0; x < kSize; ++x) {
        if (in_square(x, y, 8, 32)) {
          depth.at(x, y, 0) = zF;
          ids[0].at(x, y, 0) = kF;
        } else if (in_square(x, y, 4, 36)) {
          depth.at(x, y, 0) = zM;
          ids[0].at(x, y, 0) = kM;
        }
        // L_1 (near plane at c = -4) and L_2 (c = 0) clip F and show M behind it;
        // L_3 (c = 4) also clips M; L_4 (c = 8) shows B, which lies exactly at its near plane.
        float behind_f = in_square(x, y, 4, 36) ? kM : kB;
        ids[1].at(x, y, 0) = behind_f;
        ids[2].at(x, y, 0) = behind_f;
      }
  }

  lens::LensImaging imaging;
  PreviewOptions options;
  LayerPlan plan;
  image::Image depth;
  std::vector<image::Image> ids;
};

TEST_F(OcclusionMasks, ExactlyTheExpectedPixels) {
  std::vector<image::Image> masks = build_occlusion_masks(ids, depth, plan, imaging, options);
  ASSERT_EQ(masks.size(), 5u);
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      // mask_0, mask_1 (M is seen from L_1 and L_2 alike: revealed farther back) and mask_3 (B is
      // seen from L_3 and L_4 alike) are empty.
      EXPECT_EQ(masks[0].at(x, y, 0), 0.0f);
      EXPECT_EQ(masks[1].at(x, y, 0), 0.0f) << x << "," << y;
      EXPECT_EQ(masks[3].at(x, y, 0), 0.0f) << x << "," << y;
      // mask_2: M behind F, within reach of the lens: the nearest open pixel (M's ring, CoC 1 >=
      // c_2 = 0) at most rho + 1/2 = (c_3 - c_F) / 2 + 1/2 = (4 + 7) / 2 + 1/2 = 6 px away:
      // the 6 px ring inside F.
      bool m2 = in_square(x, y, 8, 32) && !in_square(x, y, 14, 26);
      EXPECT_EQ(masks[2].at(x, y, 0), m2 ? 1.0f : 0.0f) << "mask_2 at " << x << "," << y;
      // mask_4: B behind M and F, the nearest open pixel (B, CoC 8 >= c_4 = 8) at most
      // (8 + 7) / 2 + 1/2 = 8 px away: the 8 px ring inside M's outline.
      bool m4 = in_square(x, y, 4, 36) && !in_square(x, y, 12, 28);
      EXPECT_EQ(masks[4].at(x, y, 0), m4 ? 1.0f : 0.0f) << "mask_4 at " << x << "," << y;
    }
}

TEST_F(OcclusionMasks, WithoutTheLensReachWholeRegions) {
  options.mask_lens_reach = false;
  std::vector<image::Image> masks = build_occlusion_masks(ids, depth, plan, imaging, options);
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      EXPECT_EQ(masks[2].at(x, y, 0), in_square(x, y, 8, 32) ? 1.0f : 0.0f);
      EXPECT_EQ(masks[4].at(x, y, 0), in_square(x, y, 4, 36) ? 1.0f : 0.0f);
    }
}

TEST_F(OcclusionMasks, RejectsMismatchedInputs) {
  ids.pop_back();
  EXPECT_THROW(build_occlusion_masks(ids, depth, plan, imaging, options), Error);
}

// Rule (3) alone, at every pixel. Layer 2 (c_2 = 0, c_hi = 4; F at c = -7 is the only occluder,
// window ceil((4 + 7) / 2) = 6): F's 6 px ring; M (open, c = 1 <= c_hi + 1); and the background
// (open, but c = 8: reach (4 - 8) / 2 + 1/2 < 0) only within the 6 px window of F, where the
// occluder's CoC bounds the reach. Layer 4 (c_hi = c_4 = 8, window 8): the 8 px ring inside M's
// outline and all of the background.
TEST_F(OcclusionMasks, LensReachRegionsAreRule3Alone) {
  std::vector<image::Image> regions = lens_reach_regions(depth, plan, imaging, options);
  ASSERT_EQ(regions.size(), 5u);
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      EXPECT_EQ(regions[0].at(x, y, 0), 0.0f);
      const bool r2 = in_square(x, y, 2, 38) && !in_square(x, y, 14, 26);
      EXPECT_EQ(regions[2].at(x, y, 0), r2 ? 1.0f : 0.0f) << x << "," << y;
      EXPECT_EQ(regions[4].at(x, y, 0), in_square(x, y, 12, 28) ? 0.0f : 1.0f) << x << "," << y;
    }
  options.mask_lens_reach = false;
  regions = lens_reach_regions(depth, plan, imaging, options);
  for (int j = 1; j < 5; ++j)
    for (float v : regions[j].data()) ASSERT_EQ(v, 1.0f) << "layer " << j;
}

// What a renderer may spare: L_j left at L_0 outside region_j and outside the part of region_{j-1}
// where L_{j-1} passes rule (1). On the benchmark scene (many layers, occluders at several
// depths) the masks must not change, and the sparing must be substantial.
TEST(OcclusionRegions, IdLayersOutsideTheRegionsDoNotMatter) {
  const SyntheticScene scene = make_demo_scene(160, 120);
  const PreviewInputs in = scene.pinhole();
  PreviewOptions options;
  const LayerPlan plan = plan_layers(in.depth, in.imaging, options);
  ASSERT_GE(plan.size(), 4);
  const std::vector<image::Image> full = scene.id_layers(plan);
  const std::vector<image::Image> expected =
      build_occlusion_masks(full, in.depth, plan, in.imaging, options);
  const std::vector<image::Image> regions = lens_reach_regions(in.depth, plan, in.imaging, options);

  std::vector<image::Image> spared = full;
  std::size_t clipped = 0, kept = 0, revealed = 0;
  for (int j = 1; j < plan.size(); ++j) {
    for (std::size_t p = 0; p < in.depth.pixel_count(); ++p) {
      const float before = spared[j - 1].data()[p], id0 = in.ids.data()[p];
      const bool read = regions[j].data()[p] > 0.5f ||
                        (j >= 2 && regions[j - 1].data()[p] > 0.5f && before >= 0 && before != id0);
      clipped += in.depth.data()[p] < plan.layers[j].depth;
      kept += read && in.depth.data()[p] < plan.layers[j].depth;
      if (!read) spared[j].data()[p] = id0;
    }
    for (float v : expected[j].data()) revealed += v > 0.5f;
  }
  ASSERT_GT(revealed, 0u) << "nothing revealed: the test would prove nothing";
  const std::vector<image::Image> masks = build_occlusion_masks(spared, regions);
  ASSERT_EQ(masks.size(), expected.size());
  for (int j = 0; j < plan.size(); ++j)
    for (std::size_t p = 0; p < in.depth.pixel_count(); ++p) {
      ASSERT_EQ(masks[j].data()[p], expected[j].data()[p]) << "layer " << j << " pixel " << p;
      if (expected[j].data()[p] > 0.5f) {
        ASSERT_EQ(regions[j].data()[p], 1.0f);
      }
    }
  // Most clipped pixels need no tracing.
  EXPECT_LT(kept, clipped / 2) << kept << " of " << clipped << " clipped pixels read";
}

}  // namespace
}  // namespace dofcache::preview
