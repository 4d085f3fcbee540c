// The render's denoiser keeps shaped bokeh shaped: a lamp's bokeh through six blades and through
// an anamorphic squeeze, rendered with 64 lens samples (a lens ray in 17 meets the lamp) and
// denoised, against the same lamp converged (1024 samples, no filter). The moments of
// tests/render/lamp_bokeh.h: the corner count and a corner's angle, the size and the aspect, and
// the light (which the emission pass lost at the bokeh's rim when a pixel without measured noise
// was taken as sure of its value: 5.6 % here, more than half at 16 samples of a smaller lamp).
#include <gtest/gtest.h>

#include <cmath>

#include "../render/lamp_bokeh.h"
#include "dofcache/request/image_render.h"
#include "dofcache/scene/accel.h"

namespace dofcache::request {
namespace {

constexpr int kSize = 96;
constexpr float kYfov = 0.0572f;  // a 14 px circle of confusion at 3 m through f/2 at 1 m

struct Bokeh {
  testing::BokehMoments denoised, converged;
};

Bokeh render_lamp(const lens::ApertureShape& aperture) {
  lens::ThinLens lens{0.05, 2.0, 1.0};
  lens.aperture = aperture;
  const lens::LensImaging imaging{lens, kYfov, kSize};
  const scene::Scene s =
      testing::lamp_scene({0.0f, 0.0f, -3.0f}, 6.0 * imaging.pixel_footprint(3.0), kYfov, false);
  const scene::Accel accel(s);
  render::RenderSettings r = testing::lamp_settings(lens, kSize, 1024);
  Bokeh b;
  b.converged = testing::bokeh_moments(render::render(s, accel, s.cameras[0], r).color, 1);
  r.spp = 64;
  r.lens_features = true;
  const render::RenderOutput out = render::render(s, accel, s.cameras[0], r);
  b.denoised = testing::bokeh_moments(denoised(out, r, s.cameras[0]), 1);
  return b;
}

TEST(ShapedDenoise, BladesKeepTheirCornersThroughTheDenoiser) {
  const Bokeh b = render_lamp({6, 20.0, 0.0, 1.0, {}});
  EXPECT_EQ(b.converged.corners(), 6);
  EXPECT_EQ(b.denoised.corners(), 6);
  EXPECT_NEAR(std::remainder(b.denoised.corner_deg(6) - 20.0, 60.0), 0.0, 4.0);
  EXPECT_NEAR(std::sqrt(b.denoised.polar / b.converged.polar), 1.0, 0.05);
  EXPECT_NEAR(b.denoised.total / b.converged.total, 1.0, 0.05);
  // The corners stand out as much as in the converged image (not rounded off).
  EXPECT_GT(std::abs(b.denoised.order[6]), 0.7 * std::abs(b.converged.order[6]));
}

TEST(ShapedDenoise, AnOvalKeepsItsAspectThroughTheDenoiser) {
  const Bokeh b = render_lamp({0, 0.0, 0.0, 2.0, {}});
  // The lamp's 6 px square and the pixel add (36 + 1) / 12 px^2 to each axis's moment.
  const double extra = 37.0 / 12.0;
  EXPECT_NEAR(std::sqrt((b.converged.yy - extra) / (b.converged.xx - extra)), 2.0, 0.06);
  const double converged = std::sqrt(b.converged.yy / b.converged.xx);
  EXPECT_NEAR(std::sqrt(b.denoised.yy / b.denoised.xx) / converged, 1.0, 0.05);
  EXPECT_NEAR(b.denoised.total / b.converged.total, 1.0, 0.05);
}

}  // namespace
}  // namespace dofcache::request
