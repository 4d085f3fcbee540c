// The paper's occlusion fix end to end on a hand-built scene: a defocused red square in front of an
// in-focus grey background that hides a green patch exactly behind the square. A real lens sees
// the patch through the blurred rim of the square; the Kraus & Strengert baseline can only
// interpolate the grey around it.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "dofcache/core/error.h"
#include "dofcache/lens/aperture.h"
#include "dofcache/preview/occlusion.h"
#include "dofcache/preview/preview.h"
#include "dofcache/preview/synthetic_scene.h"

namespace dofcache::preview {
namespace {

constexpr int kSize = 128, kLo = 40, kHi = 88;  // the square [kLo, kHi)^2
constexpr double kRadius = 8.0;                 // its CoC radius

bool in_square(int x, int y) { return x >= kLo && x < kHi && y >= kLo && y < kHi; }

// `y_resolution`: the imaging's, which the layered methods' circles of confusion in pixels
// follow; the shaped scatter's camera takes the image's own height.
SyntheticScene make_scene(int y_resolution = 480) {
  SyntheticScene s;
  s.width = s.height = kSize;
  s.imaging = demo_imaging(y_resolution);
  const double square_depth = s.imaging.depth_for_signed_coc(-2.0 * kRadius);
  // A red square, a green patch hidden behind it, a grey background.
  s.rects.push_back(flat_rect(kLo, kLo, kHi, kHi, square_depth, 2, 1.0f, 0.0f, 0.0f));
  s.rects.push_back(flat_rect(kLo, kLo, kHi, kHi, 3.01, 1, 0.0f, 1.0f, 0.0f));
  s.rects.push_back(flat_rect(0, 0, kSize, kSize, 3.01, 0, 0.5f, 0.5f, 0.5f));
  return s;
}

// What the lens sees: the background is in focus, so each pixel sees its own background point
// through the part of the lens the square does not block: the fraction of the aperture around
// the pixel (the offsets (dx, dy) within kRadius + 1 that `in_aperture` accepts; by default the
// disk of radius kRadius) that lies outside the square.
image::Image expected_image(const std::function<bool(int, int)>& in_aperture =
                                [](int dx, int dy) { return dx * dx + dy * dy <= kRadius * kRadius; }) {
  image::Image out(kSize, kSize, 3);
  const int r = static_cast<int>(kRadius) + 1;
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      int inside = 0, total = 0;
      for (int dy = -r; dy <= r; ++dy)
        for (int dx = -r; dx <= r; ++dx) {
          if (!in_aperture(dx, dy)) continue;
          ++total;
          inside += in_square(x + dx, y + dy);
        }
      float cov = static_cast<float>(inside) / total;
      float bg[3] = {0.5f, 0.5f, 0.5f};
      if (in_square(x, y)) bg[0] = 0, bg[1] = 1, bg[2] = 0;
      const float red[3] = {1, 0, 0};
      for (int c = 0; c < 3; ++c) out.at(x, y, c) = cov * red[c] + (1 - cov) * bg[c];
    }
  return out;
}

int distance_to_edge(int x, int y) {
  int dx = std::max({kLo - x, x - (kHi - 1), 0}), dy = std::max({kLo - y, y - (kHi - 1), 0});
  if (in_square(x, y)) return std::min({x - kLo, kHi - 1 - x, y - kLo, kHi - 1 - y});
  return std::max(dx, dy);
}

// A preview against what the lens sees, in the ring within 10 px of the square's edge (both
// sides): the mean squared error, and the greenness g - b just inside the silhouette (zero for
// any mix of the red square and the grey background; the hidden patch makes it positive).
struct Ring {
  double mse = 0, green = 0;
};
Ring ring_of(const image::Image& preview, const image::Image& expected) {
  Ring out;
  int ring = 0, rim = 0;
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      if (distance_to_edge(x, y) > 10) continue;
      ++ring;
      for (int c = 0; c < 3; ++c) out.mse += std::pow(preview.at(x, y, c) - expected.at(x, y, c), 2);
      if (in_square(x, y) && distance_to_edge(x, y) <= 4) {  // just inside the silhouette
        ++rim;
        out.green += preview.at(x, y, 1) - preview.at(x, y, 2);
      }
    }
  out.mse /= ring, out.green /= rim;
  return out;
}

// The preview with the fix is much closer to what the lens sees in the ring than without it,
// because the rim shows the hidden green where the preview without it shows interpolated grey;
// away from the ring the fix changes nothing (it only touches revealed pixels). The ring's errors
// are recorded as ring_mse_<name>.
void expect_the_fix_shows_the_patch(const image::Image& without, const image::Image& with,
                                    const image::Image& expected, const std::string& name_without,
                                    const std::string& name_with) {
  const Ring a = ring_of(without, expected), b = ring_of(with, expected);
  ::testing::Test::RecordProperty("ring_mse_" + name_without, std::to_string(a.mse));
  ::testing::Test::RecordProperty("ring_mse_" + name_with, std::to_string(b.mse));
  EXPECT_LT(b.mse, 0.3 * a.mse) << "without the fix " << a.mse << ", with it " << b.mse;
  EXPECT_GT(b.green, 0.05) << b.green;
  EXPECT_LT(std::abs(a.green), 0.005) << a.green;
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x)
      if (distance_to_edge(x, y) > 24) {
        for (int c = 0; c < 3; ++c) ASSERT_NEAR(with.at(x, y, c), without.at(x, y, c), 1e-4);
      }
}

TEST(OcclusionFix, ShowsTheHiddenPatchInTheRing) {
  SyntheticScene scene = make_scene();
  PreviewOptions options;
  PreviewInputs inputs = scene.pinhole_with_revealed_layers(options);
  ASSERT_FALSE(inputs.revealed.empty());

  image::Image kraus = render_preview(inputs, PreviewMethod::Layered, options);
  image::Image fixed = render_preview(inputs, PreviewMethod::LayeredOcclusion, options);
  image::Image expected = expected_image();

  // The fixed preview is closer to what the lens sees (measured: 0.0011 against 0.041; both share
  // the error of the pyramid blur and of the trapezoid mattes, which widen the square's rim; the
  // revealed patch in place of the rising-ramp copy of the square removes most of the fix's).
  expect_the_fix_shows_the_patch(kraus, fixed, expected, "kraus", "occlusion_fix");
}

// The same scene through six straight blades (a corner along +x: the hexagon is the same turned
// by 180 degrees or mirrored, so the bokeh's orientation in front of the focus does not matter):
// the shaped scatter with the fix splats the revealed green patch too, and the ring matches what
// the lens sees (the hexagon's share of the square around each pixel) far better than without.
TEST(OcclusionFix, TheShapedScatterShowsTheHiddenPatchThroughSixBlades) {
  SyntheticScene scene = make_scene(kSize);
  PreviewOptions options;
  PreviewInputs inputs = scene.pinhole_with_revealed_layers(options);
  ASSERT_FALSE(inputs.revealed.empty());
  inputs.imaging.lens.aperture.blades = 6;

  PreviewTimings t_plain, t_fixed;
  image::Image plain = render_preview(inputs, PreviewMethod::Layered, options, &t_plain);
  image::Image fixed = render_preview(inputs, PreviewMethod::LayeredOcclusion, options, &t_fixed);
  ASSERT_TRUE(t_fixed.shaped_bokeh);
  EXPECT_EQ(t_plain.revealed_fragments, 0);
  EXPECT_GT(t_fixed.revealed_fragments, 0);

  // What the lens sees: the share of the hexagon of circumradius kRadius around a pixel that
  // the square covers, over the background that pixel sees (green behind the square).
  const lens::Aperture hexagon(inputs.imaging.lens.aperture);
  const image::Image expected = expected_image([&](int dx, int dy) {
    return hexagon.contains(glm::vec2(dx, dy) / static_cast<float>(kRadius));
  });
  // Measured: 0.0516 without the fix, 0.00059 with it.
  expect_the_fix_shows_the_patch(plain, fixed, expected, "shaped", "shaped_occlusion_fix");
}

TEST(OcclusionFix, RevealedLayersMustMatchThePlan) {
  SyntheticScene scene = make_scene();
  PreviewInputs inputs = scene.pinhole();
  RevealedLayer bogus;
  bogus.near_depth = 1234.5;
  bogus.color = image::Image(kSize, kSize, 3);
  bogus.depth = image::Image(kSize, kSize, 1);
  bogus.mask = image::Image(kSize, kSize, 1);
  inputs.revealed.push_back(bogus);
  EXPECT_THROW(render_preview(inputs, PreviewMethod::LayeredOcclusion, PreviewOptions{}),
               dofcache::Error);
  // Without the occlusion fix, revealed layers are ignored.
  EXPECT_NO_THROW(render_preview(inputs, PreviewMethod::Layered, PreviewOptions{}));
  // Through a shaped lens the plan does not matter, but a layer of another size is refused.
  inputs.imaging.lens.aperture.blades = 6;
  EXPECT_NO_THROW(render_preview(inputs, PreviewMethod::LayeredOcclusion, PreviewOptions{}));
  inputs.revealed.back().mask = image::Image(kSize + 1, kSize, 1);
  EXPECT_THROW(render_preview(inputs, PreviewMethod::LayeredOcclusion, PreviewOptions{}),
               dofcache::Error);
  EXPECT_NO_THROW(render_preview(inputs, PreviewMethod::Layered, PreviewOptions{}));
}

}  // namespace
}  // namespace dofcache::preview
