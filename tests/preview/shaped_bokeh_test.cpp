// The preview's bokeh against the ray tracer's for lenses that are not plain: the shaped scatter
// (preview.h) must draw every lens feature where the DRT puts its light. The DRT's bokeh is itself
// checked against the aperture's geometry (tests/render/bokeh_test.cpp); here the preview's
// matches it within 10 % in size and light, in corner count, and in a corner's angle within
// 4 degrees.
#include <gtest/gtest.h>

#include <cmath>

#include "../render/lamp_bokeh.h"
#include "scratch_dir.h"
#include "dofcache/preview/preview_renderer.h"
#include "dofcache/scene/accel.h"

namespace dofcache::preview {
namespace {

// A circle of confusion of 14 px at 3 m through f/2 at 1 m, in a frame wide enough that the
// splats at its border (normalised over their part in the frame) stay away from the bokeh.
constexpr int kSize = 96;
constexpr float kYfov = 0.0572f;
constexpr double kLampPixels = 4.0;  // a lamp of 4x4 px: many lens rays find it

struct Pair {
  image::Image drt, preview;
};

// The lamp at `lamp` through `lens`, by the DRT and by the preview (`method`).
Pair render_both(const lens::ThinLens& lens, glm::vec3 lamp, int size = kSize,
                 float yfov = kYfov, PreviewMethod method = PreviewMethod::Layered) {
  const lens::LensImaging imaging{lens, yfov, size};
  const double side = kLampPixels * imaging.pixel_footprint(-lamp.z);
  const scene::Scene s = testing::lamp_scene(lamp, side, yfov, true);
  const scene::Accel accel(s);
  render::RenderSettings r = testing::lamp_settings(lens, size, 512);
  Pair p;
  p.drt = render::render(s, accel, s.cameras[0], r).color;
  r.spp = 64;  // the pinhole image's film samples
  const ScenePreview pv = render_scene_preview(s, accel, s.cameras[0], r, method);
  EXPECT_TRUE(pv.timings.postprocess.shaped_bokeh);
  p.preview = pv.image;
  testing::dump_if_asked(p.drt, p.preview);
  return p;
}

using testing::bokeh_moments;

void expect_same_bokeh(const Pair& p, int channel, const char* what) {
  const testing::BokehMoments d = bokeh_moments(p.drt, channel), v = bokeh_moments(p.preview, channel);
  EXPECT_NEAR(v.total / d.total, 1.0, 0.05) << what << ": light";
  EXPECT_NEAR(std::sqrt(v.polar / d.polar), 1.0, 0.1) << what << ": size";
  EXPECT_NEAR(std::sqrt(v.xx / v.yy) / std::sqrt(d.xx / d.yy), 1.0, 0.1) << what << ": aspect";
  EXPECT_NEAR(v.cx, d.cx, 0.5) << what << ": centroid x";
  EXPECT_NEAR(v.cy, d.cy, 0.5) << what << ": centroid y";
}

TEST(ShapedPreview, BladesAndOvalsMatchTheRayTracedBokeh) {
  struct Case {
    int blades;
    double rotation, ratio, depth;  // behind the focus (1 m) at 3 m, in front at 0.6 m
    const char* what;
  };
  for (const Case& c : {Case{6, 20.0, 1.0, 3.0, "6 blades behind"},
                        Case{5, 90.0, 1.0, 0.6, "5 blades in front (turned)"},
                        Case{0, 0.0, 2.0, 3.0, "anamorphic 2"}}) {
    lens::ThinLens lens{0.05, 2.0, 1.0};
    lens.aperture.blades = c.blades;
    lens.aperture.rotation_deg = c.rotation;
    lens.aperture.anamorphic_ratio = c.ratio;
    const Pair p = render_both(lens, {0.0f, 0.0f, -static_cast<float>(c.depth)});
    expect_same_bokeh(p, 1, c.what);
    if (c.blades == 0) continue;
    const testing::BokehMoments d = bokeh_moments(p.drt, 1), v = bokeh_moments(p.preview, 1);
    EXPECT_EQ(d.corners(), c.blades) << c.what;
    EXPECT_EQ(v.corners(), c.blades) << c.what;
    const double off = std::remainder(v.corner_deg(c.blades) - d.corner_deg(c.blades),
                                      360.0 / c.blades);
    EXPECT_NEAR(off, 0.0, 4.0) << c.what;
  }
}

TEST(ShapedPreview, TheVignettingStopCutsTheSameCatsEye) {
  // The geometry of the DRT's own test: a lamp off the axis whose bundle the stop clips to
  // about half.
  lens::ThinLens lens{0.05, 2.0, 1.0};
  const double a = 0.0125, Z = 3.0, D = 0.5;
  lens.aperture.stop = {1.1 * a * (Z - D) / Z, D};
  const float yfov = 0.1144f;
  const float l = static_cast<float>(0.05 / std::sqrt(2.0));
  const Pair p = render_both(lens, {l, l, -static_cast<float>(Z)}, 128, yfov);
  expect_same_bokeh(p, 1, "cat's eye");
  // Half the light or so is stopped: a real cut, in both.
  lens::ThinLens open = lens;
  open.aperture.stop = {};
  open.aperture.blades = 3;  // not plain either way
  open.aperture.roundness = 1.0;
  const Pair q = render_both(open, {l, l, -static_cast<float>(Z)}, 128, yfov);
  const double share = bokeh_moments(p.preview, 1).total / bokeh_moments(q.preview, 1).total;
  EXPECT_GT(share, 0.3);
  EXPECT_LT(share, 0.8);
}

TEST(ShapedPreview, TheTransmissionProfileWeighsTheBokehAsInTheRayTracer) {
  // A rim-weighted ("soap bubble", T = rho^2 at full strength) and a centre-weighted (T =
  // 1 - rho^2) aperture: the preview draws the transmission as levels (preview/aperture_rows.h),
  // so the bokeh's light spreads as the DRT's does. Its size (the polar moment's root) is the
  // DRT's to within 2 % of the evenly lit disc's own preview-to-DRT ratio (the splats' half-pixel
  // pad makes every preview bokeh a little larger); an evenly lit disc differs from the DRT's
  // profiled bokeh by 10-20 % (polar moments R^2 / 2 against 2 R^2 / 3 and R^2 / 3).
  lens::ThinLens even{0.05, 2.0, 1.0};
  even.aperture.blades = 3;  // not plain: drawn by the shaped scatter, evenly lit
  even.aperture.roundness = 1.0;
  const Pair e = render_both(even, {0.0f, 0.0f, -3.0f});
  const double even_drt = std::sqrt(bokeh_moments(e.drt, 1).polar);
  const double even_ratio = std::sqrt(bokeh_moments(e.preview, 1).polar) / even_drt;
  for (const lens::ApertureProfile profile : {lens::ApertureProfile::Rim, lens::ApertureProfile::Centre}) {
    const char* what = profile == lens::ApertureProfile::Rim ? "rim" : "centre";
    lens::ThinLens lens{0.05, 2.0, 1.0};
    lens.aperture.profile = profile;
    lens.aperture.profile_strength = 1.0;
    const Pair p = render_both(lens, {0.0f, 0.0f, -3.0f});
    expect_same_bokeh(p, 1, what);
    const double drt = std::sqrt(bokeh_moments(p.drt, 1).polar);
    const double preview = std::sqrt(bokeh_moments(p.preview, 1).polar);
    EXPECT_NEAR(preview / drt / even_ratio, 1.0, 0.02) << what;
    EXPECT_GT(std::abs(drt / even_drt - 1.0), 0.09) << what;  // the test tells them apart
  }
}

class ShapedPreviewImage : public testing::ScratchDirTest {};

TEST_F(ShapedPreviewImage, AnApertureImagesGreyLevelsMoveTheBokehAsInTheRayTracer) {
  // The left half of the aperture passes a quarter of the right half's light: the bokeh's
  // centroid moves right behind the focus (0.6 of a half-disc's, 4 R / (3 pi)), as the DRT's;
  // drawn as its non-zero pixels it would stay centred.
  const std::string path = (dir_ / "half.exr").string();
  testing::write_half_aperture_image(path);
  lens::ThinLens lens{0.05, 2.0, 1.0};
  lens.aperture.image = path;
  const Pair p = render_both(lens, {0.0f, 0.0f, -3.0f});
  expect_same_bokeh(p, 1, "grey levels");
  EXPECT_GT(bokeh_moments(p.drt, 1).cx, 1.5);  // a shift the test sees
}

TEST(ShapedPreview, ChromaticAberrationGivesEachChannelItsOwnBokeh) {
  lens::ThinLens axial{0.05, 2.0, 1.0};
  axial.aperture.axial_ca = 0.2;
  const Pair p = render_both(axial, {0.0f, 0.0f, -3.0f});
  for (int c = 0; c < 3; ++c) expect_same_bokeh(p, c, c == 0 ? "red" : c == 1 ? "green" : "blue");
  // Red and blue differ by more than the tolerance: the test sees the bands.
  const double red = bokeh_moments(p.preview, 0).polar, blue = bokeh_moments(p.preview, 2).polar;
  EXPECT_GT(std::sqrt(blue / red), 1.25);

  // Lateral: an in-focus lamp off the axis, red magnified over blue (the layered method's name
  // does not matter: every method takes the shaped path).
  lens::ThinLens lateral{0.05, 2.0, 1.0};
  lateral.aperture.lateral_ca = 0.1;
  const double k = kSize / (2.0 * std::tan(0.5 * kYfov));
  const Pair q = render_both(lateral, {static_cast<float>(12.0 / k), static_cast<float>(8.0 / k), -1.0f},
                             kSize, kYfov, PreviewMethod::Gather);
  for (int c = 0; c < 3; ++c) {
    const testing::BokehMoments d = bokeh_moments(q.drt, c), v = bokeh_moments(q.preview, c);
    EXPECT_NEAR(v.cx, d.cx, 0.25) << c;
    EXPECT_NEAR(v.cy, d.cy, 0.25) << c;
  }
  EXPECT_GT(bokeh_moments(q.preview, 0).cx - bokeh_moments(q.preview, 2).cx, 1.0);
}

TEST(ShapedPreview, ATiltedPlaneOfFocusIsSharpWhereTheRayTracerIs) {
  // The DRT test's Scheimpflug setting: a lamp on the tilted plane, 0.03 below the axis.
  constexpr int kImage = 128;
  const double F = 0.05, P = 1.0, a = 0.05, tan_half = 0.1;
  const float yfov = static_cast<float>(2.0 * std::atan(tan_half));
  lens::ThinLens lens{F, F / (2.0 * a), P};
  lens.aperture.tilt_x_deg = std::asin(5.0 * F) * 180.0 / M_PI;
  const double z = 1.0 / (1.0 / P + 0.03 * 5.0);
  const Pair sharp = render_both(lens, {0.0f, static_cast<float>(-0.03 * z), -static_cast<float>(z)},
                                 kImage, yfov);
  const testing::BokehMoments d = bokeh_moments(sharp.drt, 1), v = bokeh_moments(sharp.preview, 1);
  EXPECT_LT(v.polar, d.polar + 0.3);  // as sharp as the lamp and the pixel make it
  EXPECT_NEAR(v.cy, d.cy, 0.3);
  // A lamp off the plane (at the untilted focus) is blurred alike in both.
  const Pair blurred = render_both(lens, {0.0f, static_cast<float>(-0.03 * P), -static_cast<float>(P)},
                                   kImage, yfov);
  expect_same_bokeh(blurred, 1, "off the tilted plane");
  EXPECT_GT(bokeh_moments(blurred.preview, 1).polar, 4.0);
}

}  // namespace
}  // namespace dofcache::preview
