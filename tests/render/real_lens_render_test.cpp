// The renderer through a real lens (lens/real_lens.h), end to end: a small lamp's bokeh in the DRT
// image has the circle of confusion the thick-lens equivalent predicts (what the cache's reuse
// rule and the preview use), the image is upright and where the paraxial projection puts it, and
// a uniform light fills the frame at its radiance (or, with the exposure following the lens, at
// the f-stop's share, darkening towards the corners).
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "dofcache/lens/real_lens.h"
#include "dofcache/render/renderer.h"
#include "lamp_bokeh.h"
#include "scratch_dir.h"

namespace dofcache::render {
namespace {

constexpr int kSize = 96;

lens::MountedLens double_gauss(double fstop, double focus, bool exposure = false,
                               double sensor = 0.008, const lens::ApertureShape& stop = {}) {
  const std::string path = std::string(DOFCACHE_SOURCE_DIR) + "/scenes/lenses/double_gauss_50mm.lens";
  lens::Sensor s;
  s.width = s.height = sensor;  // a small square sensor: large bokeh in few pixels
  return lens::mount_lens(lens::read_lens_file(path), path, fstop, focus, s, kSize, kSize,
                          exposure, stop);
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

// The lamps of the test above through a shaped stop, wide open, focused at 1 m from the sensor:
// 0.5 m in front of the focus, 6 m behind.
struct LampAt {
  double distance, coc;  // metres from the sensor; the equivalent's circle of confusion, pixels
  testing::BokehMoments bokeh;
};
std::vector<LampAt> lamp_bokeh(const lens::ApertureShape& stop, int spp) {
  const lens::MountedLens m = double_gauss(0.0, 1.0, false, 0.006, stop);
  const lens::LensImaging imaging{m.equivalent(), m.yfov(), kSize};
  std::vector<LampAt> out;
  for (double distance : {0.5, 6.0}) {
    const double depth = distance - m.principal_offset();
    const double side = 2.5 * imaging.pixel_footprint(depth);
    const scene::Scene s =
        testing::lamp_scene({0.0f, 0.0f, -static_cast<float>(distance)}, side, 0.5f);
    out.push_back({distance, imaging.coc_radius_pixels(depth),
                   testing::bokeh_moments(render_through(m, s, spp), 1)});
  }
  return out;
}

constexpr double kLampPolar = (2.5 * 2.5 + 1.0) / 6.0;  // the lamp's square and the pixel's box

TEST(RealLensRender, BladedStopGivesItsPolygonUprightBehindTheFocusAndTurnedInFront) {
  // Five blades, a corner straight up: behind the focus the bokeh is upright (the exit pupil is
  // the stop's upright image), in front of it turned by 180 degrees, as through a thin lens.
  constexpr int kBlades = 5;
  for (const LampAt& lamp : lamp_bokeh({kBlades, 90.0, 0.0, 1.0, {}}, 1024)) {
    SCOPED_TRACE(lamp.distance);
    const testing::BokehMoments& b = lamp.bokeh;
    EXPECT_EQ(b.corners(), kBlades);
    const double expected = lamp.distance > 1.0 ? 90.0 : 270.0;
    EXPECT_NEAR(std::remainder(b.corner_deg(kBlades) - expected, 360.0 / kBlades), 0.0, 3.0)
        << b.corner_deg(kBlades);
    // A regular N-gon of circumradius R: polar moment R^2 (1 + 2 cos^2(pi / N)) / 6. The stop's
    // polygon is inscribed in the round stop, so R is the equivalent's circle of confusion.
    const double c = std::cos(M_PI / kBlades);
    const double radius = std::sqrt((b.polar - kLampPolar) * 6.0 / (1.0 + 2.0 * c * c));
    EXPECT_NEAR(radius, lamp.coc, 0.05 * lamp.coc);
  }
}

TEST(RealLensRender, AnamorphicStopGivesAnOvalTwiceAsTallAsWide) {
  for (const LampAt& lamp : lamp_bokeh({0, 0.0, 0.0, 2.0, {}}, 1024)) {
    SCOPED_TRACE(lamp.distance);
    // An ellipse's second moment along an axis is a quarter of that semi-axis squared.
    const double extra = (2.5 * 2.5 + 1.0) / 12.0;
    const double tall = std::sqrt(4.0 * (lamp.bokeh.yy - extra));
    const double wide = std::sqrt(4.0 * (lamp.bokeh.xx - extra));
    EXPECT_NEAR(tall / wide, 2.0, 0.06 * 2.0);
    EXPECT_NEAR(tall, lamp.coc, 0.05 * lamp.coc);
  }
}

class RealLensImageStop : public testing::ScratchDirTest {};

TEST_F(RealLensImageStop, ApertureImageTransmitsItsGreyLevels) {
  // The stop's right half passes everything, its left half a quarter. The bokeh is the disc with
  // that transmission, upright behind the focus: its centroid lies (1 - 1/4) / (1 + 1/4) of a
  // half-disc's, 4 R / (3 pi), to the right; in front of the focus as far to the left.
  const std::string path = (dir_ / "half.exr").string();
  testing::write_half_aperture_image(path);
  lens::ApertureShape stop;
  stop.image = path;
  for (const LampAt& lamp : lamp_bokeh(stop, 512)) {
    SCOPED_TRACE(lamp.distance);
    const double offset = 0.75 / 1.25 * 4.0 * lamp.coc / (3.0 * M_PI);
    EXPECT_NEAR(lamp.bokeh.cx, lamp.distance > 1.0 ? offset : -offset, 0.05 * offset);
    EXPECT_NEAR(lamp.bokeh.cy, 0.0, 0.25);
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
  // A shaped stop (six blades, a rim-weighted profile) passes less light than the round one;
  // normalised per distance from the centre, it still images the light at its radiance.
  const lens::ApertureShape shaped(6, 10.0, 0.0, 1.0, {}, 0.0, 0.0, lens::ApertureProfile::Rim, 1.0);
  const image::Image bladed = render_through(double_gauss(4.0, 3.0, false, 0.036, shaped), s, 64);
  for (auto [x, y] : {std::pair{48, 48}, std::pair{6, 6}, std::pair{89, 89}})
    EXPECT_NEAR(patch_mean(bladed, x, y), 1.0, 0.03) << x << "," << y;
}

TEST(RealLensRender, TheEquivalentsBokehSeesTheFittedRims) {
  // lens/lens_rims.h: a point at the focus distance seen at film point f (lens space) sees the
  // stop through the discs of centres slope * f and the fitted radii; the equivalent carries
  // them as a front and a rear stop, and ThinLensCamera::bokeh must give those discs back.
  const std::string path = "double_gauss_50mm";
  constexpr int kW = 300, kH = 200;
  const lens::MountedLens m = lens::mount_lens(lens::read_lens_file(path), path, 0.0, 3.0,
                                               lens::Sensor{}, kW, kH, false);
  ASSERT_TRUE(m.lens->rims().front.present() && m.lens->rims().rear.present());
  const lens::ThinLens thin = m.equivalent();
  const ThinLensCamera camera(glm::mat4(1.0f), 0.5f, thin, kW, kH, m);
  for (const glm::vec2 px : {glm::vec2(150.0f, 100.0f), glm::vec2(290.0f, 100.0f),
                             glm::vec2(20.0f, 185.0f), glm::vec2(230.0f, 10.0f)}) {
    SCOPED_TRACE(px.x);
    const glm::dvec2 f{(0.5 - px.x / kW) * m.film_size.x, (px.y / kH - 0.5) * m.film_size.y};
    const BokehSpot b = camera.bokeh(px, thin.focus_distance);
    EXPECT_TRUE(b.normalised);
    const lens::RimDisc* rims[2] = {&m.lens->rims().front, &m.lens->rims().rear};
    for (int k = 0; k < 2; ++k) {
      ASSERT_TRUE(b.stops[k].present());
      EXPECT_NEAR(b.stops[k].radius, rims[k]->radius, 1e-4);
      EXPECT_NEAR(b.stops[k].centre.x, rims[k]->slope * f.x, 1e-4);
      EXPECT_NEAR(b.stops[k].centre.y, rims[k]->slope * f.y, 1e-4);
    }
  }
}

}  // namespace
}  // namespace dofcache::render
