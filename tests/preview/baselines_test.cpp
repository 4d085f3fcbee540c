// The single-layer baselines (baselines.h): gather's bleeding guard, scatter's depth order.
#include "dofcache/preview/baselines.h"
#include "dofcache/preview/synthetic_scene.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace dofcache::preview {
namespace {

constexpr int kW = 96, kH = 80;

lens::LensImaging test_imaging() { return demo_imaging(480); }

bool in_square(int x, int y) { return x >= 36 && x < 60 && y >= 28 && y < 52; }

// A red square at `square_depth` over a green/blue checker background at `background_depth`.
void make_scene(double square_depth, double background_depth, image::Image& color,
                image::Image& depth) {
  color = image::Image(kW, kH, 3);
  depth = image::Image(kW, kH, 1);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      bool sq = in_square(x, y);
      bool odd = ((x / 4) + (y / 4)) & 1;
      color.at(x, y, 0) = sq ? 1.0f : 0.0f;
      color.at(x, y, 1) = sq ? 0.0f : (odd ? 0.9f : 0.2f);
      color.at(x, y, 2) = sq ? 0.0f : (odd ? 0.1f : 0.8f);
      depth.at(x, y, 0) = static_cast<float>(sq ? square_depth : background_depth);
    }
}

// The largest checker contrast left in a background region far from the square.
float background_contrast(const image::Image& img) {
  float lo = 1e9f, hi = -1e9f;
  for (int y = 4; y < 20; ++y)
    for (int x = 4; x < 30; ++x) {
      lo = std::min(lo, img.at(x, y, 1));
      hi = std::max(hi, img.at(x, y, 1));
    }
  return hi - lo;
}

TEST(Gather, SharpForegroundDoesNotBleedOntoTheBlurredBackground) {
  image::Image color, depth;
  // Square in focus; background at infinity (CoC radius about 4.6 px).
  make_scene(3.0, std::numeric_limits<double>::infinity(), color, depth);
  lens::LensImaging im = test_imaging();
  for (auto blur : {&gather_blur, &scatter_blur}) {
    image::Image out = blur(color, depth, im, PreviewOptions{});
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) {
        if (in_square(x, y)) {
          // ... and the blurred background does not bleed onto the sharp square.
          ASSERT_FLOAT_EQ(out.at(x, y, 0), 1.0f) << x << "," << y;
          ASSERT_NEAR(out.at(x, y, 1), 0.0f, 1e-6f) << x << "," << y;
        } else {
          // The square's CoC is below a pixel: its red reaches no background pixel.
          ASSERT_NEAR(out.at(x, y, 0), 0.0f, 1e-6f) << x << "," << y;
        }
      }
    EXPECT_LT(background_contrast(out), 0.5f * 0.7f);  // the background is blurred
  }
}

TEST(Gather, BlurredForegroundSpreadsOverTheSharpBackground) {
  image::Image color, depth;
  lens::LensImaging im = test_imaging();
  // Square in front (CoC radius 8 px), background in focus.
  make_scene(im.depth_for_signed_coc(-16.0), 3.0, color, depth);
  for (auto blur : {&gather_blur, &scatter_blur}) {
    image::Image out = blur(color, depth, im, PreviewOptions{});
    // Just outside the square the red spreads over the background; 9 px away it does not.
    EXPECT_GT(out.at(35, 40, 0), 0.2f);
    EXPECT_NEAR(out.at(26, 40, 0), 0.0f, 1e-6f);
    // The in-focus background away from the square keeps its checker exactly.
    EXPECT_NEAR(out.at(10, 10, 1), color.at(10, 10, 1), 1e-6f);
  }
}

TEST(Scatter, NearSplatsCoverFarOnes) {
  image::Image color, depth;
  lens::LensImaging im = test_imaging();
  // Square in front (radius 8 px) over a blurred background behind focus.
  make_scene(im.depth_for_signed_coc(-16.0), std::numeric_limits<double>::infinity(), color, depth);
  image::Image out = scatter_blur(color, depth, im, PreviewOptions{});
  // Deep inside the square (more than its radius from the edge) it is opaque red.
  for (int y = 38; y < 42; ++y)
    for (int x = 46; x < 50; ++x) {
      EXPECT_NEAR(out.at(x, y, 0), 1.0f, 1e-5f);
      EXPECT_NEAR(out.at(x, y, 1), 0.0f, 1e-5f);
    }
}

}  // namespace
}  // namespace dofcache::preview
