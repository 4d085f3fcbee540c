// Every method returns the input where nothing is out of focus: zero aperture, everything at the
// focus distance, CoC below a pixel, and in-focus regions away from blurred objects.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "dofcache/preview/preview.h"

namespace dofcache::preview {
namespace {

constexpr PreviewMethod kMethods[] = {PreviewMethod::Gather, PreviewMethod::Scatter,
                                      PreviewMethod::Layered, PreviewMethod::LayeredOcclusion};

lens::LensImaging imaging(double fstop) {
  lens::LensImaging im;
  im.lens = lens::ThinLens{0.05, fstop, 3.0};
  im.yfov = 0.6;
  im.y_resolution = 480;
  return im;
}

// Random colours; depth from `depth_at(x, y)`.
template <class Depth>
PreviewInputs make_inputs(int w, int h, const lens::LensImaging& im, const Depth& depth_at) {
  PreviewInputs in;
  in.imaging = im;
  in.color = image::Image(w, h, 3);
  in.depth = image::Image(w, h, 1);
  in.ids = image::Image(w, h, 1, 0.0f);
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(0.0f, 2.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      for (int c = 0; c < 3; ++c) in.color.at(x, y, c) = u(rng);
      in.depth.at(x, y, 0) = depth_at(x, y);
    }
  return in;
}

void expect_unchanged(const image::Image& out, const image::Image& in, const char* what,
                      PreviewMethod m) {
  ASSERT_TRUE(out.same_shape(in));
  for (size_t i = 0; i < in.data().size(); ++i)
    ASSERT_NEAR(out.data()[i], in.data()[i], 1e-6f * std::max(1.0f, std::abs(in.data()[i])))
        << what << ", " << preview_method_name(m) << ", value " << i;
}

TEST(PassThrough, EverythingAtTheFocusDistance) {
  PreviewInputs in = make_inputs(53, 31, imaging(1.4), [](int, int) { return 3.0f; });
  for (PreviewMethod m : kMethods)
    expect_unchanged(render_preview(in, m, PreviewOptions{}), in.color, "in focus", m);
}

TEST(PassThrough, ZeroAperture) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> d(0.2f, 60.0f);
  auto depth = [&](int x, int) {
    return x % 7 == 0 ? std::numeric_limits<float>::infinity() : d(rng);
  };
  for (double fstop : {std::numeric_limits<double>::infinity(), 1e9}) {
    PreviewInputs in = make_inputs(40, 30, imaging(fstop), depth);
    for (PreviewMethod m : kMethods)
      expect_unchanged(render_preview(in, m, PreviewOptions{}), in.color, "zero aperture", m);
  }
}

TEST(PassThrough, CircleOfConfusionBelowOnePixel) {
  // f/400: the background's CoC is well under a pixel.
  lens::LensImaging im = imaging(400.0);
  ASSERT_LT(std::abs(im.signed_coc_pixels(1e6)), 1.0);
  PreviewInputs in = make_inputs(40, 30, im, [](int x, int y) { return 1.0f + 0.3f * (x + y); });
  for (PreviewMethod m : kMethods)
    expect_unchanged(render_preview(in, m, PreviewOptions{}), in.color, "sub-pixel CoC", m);
}

TEST(PassThrough, InFocusRegionsAwayFromBlurredObjectsStayExact) {
  // An in-focus backdrop with a strongly defocused square near one corner.
  lens::LensImaging im = imaging(1.4);
  const float near = static_cast<float>(im.depth_for_signed_coc(-20.0));  // radius 10 px
  const int w = 120, h = 90;
  auto in_square = [](int x, int y) { return x >= 10 && x < 30 && y >= 10 && y < 30; };
  PreviewInputs in =
      make_inputs(w, h, im, [&](int x, int y) { return in_square(x, y) ? near : 3.0f; });
  for (PreviewMethod m : kMethods) {
    image::Image out = render_preview(in, m, PreviewOptions{});
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        if (x < 30 + 40 && y < 30 + 40) continue;  // within 40 px of the square
        for (int c = 0; c < 3; ++c)
          ASSERT_NEAR(out.at(x, y, c), in.color.at(x, y, c), 1e-5f)
              << preview_method_name(m) << " at " << x << "," << y;
      }
  }
}

}  // namespace
}  // namespace dofcache::preview
