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

}  // namespace
}  // namespace dofcache::preview
