// The renderer through a real lens (lens/real_lens.h), end to end: a small lamp's bokeh in the DRT
// image has the circle of confusion the thick-lens equivalent predicts (what the cache's reuse
// rule and the preview use), the image is upright and where the paraxial projection puts it, and
// a uniform light fills the frame at its radiance (or, with the exposure following the lens, at
// the f-stop's share, darkening towards the corners).
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "dofcache/lens/real_lens.h"
#include "dofcache/render/renderer.h"
#include "lamp_bokeh.h"

namespace dofcache::render {
namespace {

constexpr int kSize = 96;

lens::MountedLens double_gauss(double fstop, double focus, bool exposure = false,
                               double sensor = 0.008) {
  const std::string path = std::string(DOFCACHE_SOURCE_DIR) + "/scenes/lenses/double_gauss_50mm.lens";
  lens::Sensor s;
  s.width = s.height = sensor;  // a small square sensor: large bokeh in few pixels
  return lens::mount_lens(lens::read_lens_file(path), path, fstop, focus, s, kSize, kSize,
                          exposure);
}

image::Image render_through(const lens::MountedLens& m, const scene::Scene& s, int spp) {
  scene::Accel accel(s);
  RenderSettings r = testing::lamp_settings(m.equivalent(), kSize, spp);
  r.real_lens = m;
  return render(s, accel, s.cameras[0], r).color;
}

TEST(RealLensRender, LampBokehHasTheThickLensCircleOfConfusion) {
  // Focused at 1 m from the sensor, wide open; lamps at 0.5 m (in front) and 6 m (behind).
  const lens::MountedLens m = double_gauss(0.0, 1.0, false, 0.006);
  const lens::LensImaging imaging{m.equivalent(), m.yfov(), kSize};
  for (double distance : {0.5, 6.0}) {
    SCOPED_TRACE(distance);
    // The equivalent thin lens sits at the front principal plane.
    const double depth = distance - m.principal_offset();
    const double coc = imaging.coc_radius_pixels(depth);
    EXPECT_GT(coc, 8.0);  // the scene is as intended
    const double side = 2.5 * imaging.pixel_footprint(depth);
    const scene::Scene s =
        testing::lamp_scene({0.0f, 0.0f, -static_cast<float>(distance)}, side, 0.5f);
    const testing::BokehMoments b = testing::bokeh_moments(render_through(m, s, 1024), 1);
    // A uniform disc of radius R has polar moment R^2 / 2; the lamp's square and the pixel's box
    // add side^2 / 6 each.
    EXPECT_NEAR(std::sqrt(2.0 * (b.polar - (2.5 * 2.5 + 1.0) / 6.0)), coc, 0.05 * coc);
    EXPECT_NEAR(b.cx, 0.0, 0.25);
    EXPECT_NEAR(b.cy, 0.0, 0.25);
    for (int k : {1, 2, 3}) EXPECT_LT(std::abs(b.order[k]), 0.03) << k;  // round, centred
  }
}

TEST(RealLensRender, ImageIsUprightWhereTheParaxialProjectionPutsIt) {
  // A lamp in focus, up and to the right of the axis: the lens turns the image over on the film,
  // and the camera turns it back.
  const lens::MountedLens m = double_gauss(8.0, 2.0, false, 0.024);
  const double depth = 2.0 - m.principal_offset();
  const glm::vec3 lamp{0.15f, 0.1f, -2.0f};
  const scene::Scene s = testing::lamp_scene(lamp, 0.01, 0.5f);
  const testing::BokehMoments b = testing::bokeh_moments(render_through(m, s, 64), 1);
  // Paraxial: slope over tan(yfov / 2), in half image heights.
  const double pixels_per_slope = 0.5 * kSize / std::tan(0.5 * m.yfov());
  EXPECT_NEAR(b.cx, lamp.x / depth * pixels_per_slope, 0.5);
  EXPECT_NEAR(b.cy, lamp.y / depth * pixels_per_slope, 0.5);
  EXPECT_GT(b.cx, 5.0);
  EXPECT_GT(b.cy, 3.0);
}

// The mean of a square of pixels around (x, y).
double patch_mean(const image::Image& im, int x, int y) {
  double sum = 0;
  for (int j = y - 3; j <= y + 3; ++j)
    for (int i = x - 3; i <= x + 3; ++i) sum += im.at(i, j, 1);
  return sum / 49.0;
}

TEST(RealLensRender, UniformLightFillsTheFrameAtItsRadianceOrTheStopsShare) {
  // An emitter of radiance 1 fills the view; the full 36 x 24 mm frame's corners are 21 mm off
  // the axis.
  const scene::Scene s = testing::lamp_scene({0.0f, 0.0f, -3.0f}, 100.0, 0.5f);
  const image::Image even = render_through(double_gauss(4.0, 3.0, false, 0.036), s, 64);
  for (auto [x, y] : {std::pair{48, 48}, std::pair{6, 6}, std::pair{89, 89}, std::pair{6, 89}})
    EXPECT_NEAR(patch_mean(even, x, y), 1.0, 0.03) << x << "," << y;
  // Following the lens: f/4 is two stops below its f/2 widest, so the centre gets a quarter;
  // the corners less still.
  const lens::MountedLens f4 = double_gauss(4.0, 1e30, true, 0.036);
  const double share = std::pow(f4.lens->widest_fstop() / 4.0, 2.0);
  const image::Image camera = render_through(f4, s, 64);
  EXPECT_NEAR(patch_mean(camera, 48, 48), share, 0.03 * share);
  EXPECT_LT(patch_mean(camera, 6, 6), 0.9 * share);
}

}  // namespace
}  // namespace dofcache::render
