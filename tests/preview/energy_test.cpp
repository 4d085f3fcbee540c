// Blurring preserves energy: a constant image stays constant under every method, whatever the
// depths. Also: cropping the layers and the thread count do not change the layered image.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "dofcache/preview/occlusion.h"
#include "dofcache/preview/preview.h"
#include "dofcache/preview/synthetic_scene.h"

namespace dofcache::preview {
namespace {

constexpr PreviewMethod kMethods[] = {PreviewMethod::Gather, PreviewMethod::Scatter,
                                      PreviewMethod::Layered, PreviewMethod::LayeredOcclusion};

// The demo scene with every surface painted the same colour.
SyntheticScene constant_scene(int w, int h, const float rgb[3]) {
  SyntheticScene s = make_demo_scene(w, h);
  for (SyntheticRect& r : s.rects) {
    std::copy(rgb, rgb + 3, r.color);
    std::copy(rgb, rgb + 3, r.color2);
  }
  std::copy(rgb, rgb + 3, s.background);
  return s;
}

TEST(Energy, BlurredConstantImageStaysConstant) {
  const float rgb[3] = {0.3f, 0.6f, 0.9f};
  PreviewOptions options;
  PreviewInputs in = constant_scene(160, 120, rgb).pinhole_with_revealed_layers(options);
  ASSERT_FALSE(in.revealed.empty());
  for (bool blend : {true, false}) {
    options.blend_pyramid_levels = blend;
    for (PreviewMethod m : kMethods) {
      image::Image out = render_preview(in, m, options);
      for (int y = 0; y < out.height(); ++y)
        for (int x = 0; x < out.width(); ++x)
          for (int c = 0; c < 3; ++c)
            ASSERT_NEAR(out.at(x, y, c), rgb[c], 2e-5f)
                << preview_method_name(m) << (blend ? "" : " (no level blend)") << " at " << x
                << "," << y;
    }
  }
}

TEST(Energy, TinyAndOddSizes) {
  const float rgb[3] = {0.25f, 0.5f, 1.5f};
  const lens::LensImaging im = demo_imaging(480);
  const float depths[] = {0.6f, 1.1f, 3.0f, 7.0f, std::numeric_limits<float>::infinity()};
  for (auto [w, h] : {std::pair{1, 1}, {1, 7}, {7, 1}, {2, 2}, {3, 5}, {17, 9}, {33, 31}}) {
    PreviewInputs in;
    in.imaging = im;
    in.color = image::Image(w, h, 3);
    in.depth = image::Image(w, h, 1);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        std::copy(rgb, rgb + 3, in.color.pixel(x, y));
        in.depth.at(x, y, 0) = depths[(x * 7 + y * 3) % 5];
      }
    for (PreviewMethod m : kMethods) {
      image::Image out = render_preview(in, m, PreviewOptions{});
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
          for (int c = 0; c < 3; ++c)
            ASSERT_NEAR(out.at(x, y, c), rgb[c], 2e-5f)
                << preview_method_name(m) << " " << w << "x" << h;
    }
  }
}

TEST(Energy, LayerCroppingAndThreadCountDoNotChangeTheImage) {
  SyntheticScene s = make_demo_scene(200, 150);
  PreviewOptions options;
  PreviewInputs in = s.pinhole_with_revealed_layers(options);
  for (PreviewMethod m : {PreviewMethod::Layered, PreviewMethod::LayeredOcclusion}) {
    options.crop_layers = true;
    options.threads = 1;
    image::Image cropped = render_preview(in, m, options);
    options.crop_layers = false;
    image::Image whole = render_preview(in, m, options);
    options.crop_layers = true;
    options.threads = 2;
    image::Image two_threads = render_preview(in, m, options);
    EXPECT_EQ(cropped.data(), whole.data()) << preview_method_name(m);
    EXPECT_EQ(cropped.data(), two_threads.data()) << preview_method_name(m);
  }
}

TEST(Energy, TimingsAreReported) {
  SyntheticScene s = make_demo_scene(160, 120);
  PreviewOptions options;
  PreviewInputs in = s.pinhole_with_revealed_layers(options);
  PreviewTimings t;
  render_preview(in, PreviewMethod::LayeredOcclusion, options, &t);
  EXPECT_GT(t.layers, 1);
  EXPECT_GT(t.layers_blurred, 0);
  EXPECT_GT(t.total_ms, 0.0);
  EXPECT_GE(t.total_ms, t.blur_blend_ms);
  render_preview(in, PreviewMethod::Gather, options, &t);
  EXPECT_GT(t.filter_ms, 0.0);
  EXPECT_EQ(t.layers, 0);
}

}  // namespace
}  // namespace dofcache::preview
