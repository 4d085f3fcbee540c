// The preview through a real lens against the traced lens's own render: towards the frame's edge
// the lens's rims cut a defocused lamp's bokeh to a cat's eye, and the preview draws the same one
// (lens/lens_rims.h: the rims as two stops of the thick-lens equivalent), where it drew a round
// disc before.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "../render/lamp_bokeh.h"
#include "dofcache/lens/real_lens.h"
#include "dofcache/preview/preview_renderer.h"
#include "dofcache/scene/accel.h"

namespace dofcache::preview {
namespace {

constexpr int kWidth = 180, kHeight = 120;  // 0.2 mm pixels on the 36 x 24 mm sensor

struct Lamp {
  double x_px;      // its image's offset right of the centre, pixels
  double distance;  // metres from the sensor
};

struct Pair {
  image::Image drt, preview;
  double coc = 0;  // the equivalent's circle of confusion (radius, pixels)
};

// The double Gauss wide open focused at 0.5 m from the sensor, a small lamp far behind the focus;
// the DRT renders only a window around its bokeh.
Pair render_both(const Lamp& lamp, bool exposure_follows_lens = false) {
  const lens::MountedLens m = lens::mount_lens(
      lens::read_lens_file("double_gauss_50mm"), "double_gauss_50mm", 0.0, 0.5, lens::Sensor{},
      kWidth, kHeight, exposure_follows_lens);
  const lens::ThinLens thin = m.equivalent();
  const lens::LensImaging imaging{thin, m.yfov(), kHeight};
  const double depth = lamp.distance - m.principal_offset();
  const double side = 2.5 * imaging.pixel_footprint(depth);
  const double x = lamp.x_px * imaging.pixel_pitch() / thin.film_distance() * depth;
  const scene::Scene s = testing::lamp_scene(
      {static_cast<float>(x), 0.0f, -static_cast<float>(lamp.distance)}, side,
      static_cast<float>(m.yfov()), true);
  const scene::Accel accel(s);
  render::RenderSettings r = testing::lamp_settings(thin, kWidth, 512);
  r.height = kHeight;
  r.real_lens = m;
  Pair p;
  p.coc = imaging.coc_radius_pixels(depth);
  image::Image window(kWidth, kHeight, 1, 0.0f);
  const int reach = static_cast<int>(p.coc) + 5;
  for (int yy = kHeight / 2 - reach; yy < kHeight / 2 + reach; ++yy)
    for (int xx = static_cast<int>(kWidth / 2 + lamp.x_px) - reach;
         xx < static_cast<int>(kWidth / 2 + lamp.x_px) + reach; ++xx)
      if (xx >= 0 && yy >= 0 && xx < kWidth && yy < kHeight) window.at(xx, yy, 0) = 1.0f;
  r.mask = &window;
  p.drt = render::render(s, accel, s.cameras[0], r).color;
  r.mask = nullptr;
  r.spp = 64;  // the pinhole image's film samples
  const ScenePreview pv = render_scene_preview(s, accel, s.cameras[0], r, PreviewMethod::Layered);
  EXPECT_TRUE(pv.timings.postprocess.shaped_bokeh);
  p.preview = pv.image;
  testing::dump_if_asked(p.drt, p.preview);
  return p;
}

// The bokeh's radial (x) and tangential (y) extents: a disc's second moments are R^2 / 4.
double aspect(const testing::BokehMoments& b) { return std::sqrt(b.xx / b.yy); }

TEST(RealLensPreview, TheRimsCutTheSameCatsEyeAsTheTracedLens) {
  for (const Lamp& lamp : {Lamp{0.0, 10.0}, Lamp{70.0, 10.0}}) {
    SCOPED_TRACE(lamp.x_px);
    const Pair p = render_both(lamp);
    EXPECT_GT(p.coc, 6.0);  // the scene is as intended
    const testing::BokehMoments d = testing::bokeh_moments(p.drt, 1);
    const testing::BokehMoments v = testing::bokeh_moments(p.preview, 1);
    EXPECT_NEAR(v.total / d.total, 1.0, 0.06) << "light";
    EXPECT_NEAR(std::sqrt(v.polar / d.polar), 1.0, 0.1) << "size";
    EXPECT_NEAR(aspect(v) / aspect(d), 1.0, 0.1) << "aspect " << aspect(v) << " " << aspect(d);
    // The preview's paraxial projection leaves the lens's distortion out (1 px at 70 px here).
    EXPECT_NEAR(v.cx, d.cx, 1.5) << "centroid x";
    EXPECT_NEAR(v.cy, d.cy, 0.5) << "centroid y";
    if (lamp.x_px > 0.0) {
      // A real cut: the traced cat's eye is far from round, and the equivalent's round disc of
      // the same circle of confusion far from it.
      EXPECT_LT(aspect(d), 0.8);  // measured 0.73 (the preview's 0.74)
    }
  }
}

TEST(RealLensPreview, WithTheExposureFollowingTheLensTheCatsEyeDarkensAsTraced) {
  // The traced image is then not divided by what the rims pass: the edge's lamp keeps the
  // share of the centre's light that its bundle keeps, in the preview as in the DRT. The traced
  // image also falls off as cos^4 of the angle at which the film point sees the exit pupil,
  // which the preview's pinhole inputs leave out.
  const Pair centre = render_both({0.0, 10.0}, true), edge = render_both({70.0, 10.0}, true);
  const double drt = testing::bokeh_moments(edge.drt, 1).total /
                     testing::bokeh_moments(centre.drt, 1).total;
  const double preview = testing::bokeh_moments(edge.preview, 1).total /
                         testing::bokeh_moments(centre.preview, 1).total;
  const lens::MountedLens m = lens::mount_lens(lens::read_lens_file("double_gauss_50mm"),
                                               "double_gauss_50mm", 0.0, 0.5, lens::Sensor{},
                                               kWidth, kHeight, true);
  const double h = 70.0 * m.film_size.y / kHeight, z = m.lens->cardinal().exit_pupil_z;
  const double cos2 = z * z / (z * z + h * h);
  EXPECT_LT(drt, 0.75);  // a real loss
  EXPECT_NEAR(preview * cos2 * cos2 / drt, 1.0, 0.06) << preview << " " << drt;
}

}  // namespace
}  // namespace dofcache::preview
