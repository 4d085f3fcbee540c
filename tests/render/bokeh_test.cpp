// The bokeh of a small lamp far behind the focus, in the DRT image, against the aperture's
// geometry computed here: its area moments. For a regular N-gon of circumradius R the polar
// moment per area is R^2 (1 + 2 cos^2(pi / N)) / 6 (a disc's R^2 / 2); its angular moment of
// order N, the sum of I r^2 e^{i N theta}, has the phase N times a corner's angle and vanishes
// for orders that are not multiples of N; an oval's second moments along its axes are in the
// ratio of its axes squared. The lamp's own square and the pixel's box add their moments (side^2
// / 6 each, polar), which the predictions include.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>

#include "dofcache/render/renderer.h"
#include "test_scenes.h"

namespace dofcache::render {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kSize = 48;
constexpr double kDepth = 3.0;  // the lamp; the focus is at 1 m
constexpr double kLampPixels = 1.5;

struct Moments {
  double polar = 0, xx = 0, yy = 0;     // per unit intensity, pixels^2
  std::complex<double> order[17] = {};  // sum I r^2 e^{i m theta} / sum I r^2
  double cx = 0, cy = 0;
};

// Renders the lamp through `aperture` and takes the bokeh's moments about its centroid (image
// y up, so angles count counter-clockwise as the aperture's do).
Moments bokeh(const lens::ApertureShape& aperture, double* coc_pixels) {
  lens::ThinLens lens{0.05, 2.0, 1.0};
  lens.aperture = aperture;
  // A field of view that makes the circle of confusion about 14 pixels in radius.
  const float yfov = 0.0286f;
  const lens::LensImaging imaging{lens, yfov, kSize};
  *coc_pixels = imaging.coc_radius_pixels(kDepth);
  const double side = kLampPixels * imaging.pixel_footprint(kDepth);

  scene::Scene s;
  s.materials.push_back(testing::emissive_material({1.0f, 1.0f, 1.0f}));
  const float h = static_cast<float>(side / 2);
  testing::add_quad_z(s, -h, h, -h, h, -static_cast<float>(kDepth), 0, 0);
  testing::build_emitters(s);
  s.cameras.push_back(testing::origin_camera(yfov));
  scene::Accel accel(s);
  RenderSettings r;
  r.width = r.height = kSize;
  r.spp = 4096;
  r.lens = lens;
  r.threads = 2;
  r.progress = Progress::Display::Never;
  const RenderOutput out = render(s, accel, s.cameras[0], r);

  Moments m;
  double total = 0;
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      const double v = out.color.at(x, y, 1);
      total += v, m.cx += v * (x + 0.5), m.cy += v * (kSize - y - 0.5);
    }
  m.cx /= total, m.cy /= total;
  double weight = 0;
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      const double v = out.color.at(x, y, 1);
      const double dx = x + 0.5 - m.cx, dy = kSize - y - 0.5 - m.cy;
      const double r2 = dx * dx + dy * dy;
      m.xx += v * dx * dx, m.yy += v * dy * dy;
      weight += v * r2;
      for (int k = 1; k <= 16; ++k) m.order[k] += v * r2 * std::polar(1.0, k * std::atan2(dy, dx));
    }
  m.polar = weight / total, m.xx /= total, m.yy /= total;
  for (auto& o : m.order) o /= weight;
  return m;
}

// The lamp's square and the pixel's box: each side^2 / 6 of polar moment, side^2 / 12 per axis.
constexpr double kExtraPolar = (kLampPixels * kLampPixels + 1.0) / 6.0;

TEST(Bokeh, RoundApertureGivesADiscOfTheCircleOfConfusion) {
  double coc = 0;
  const Moments m = bokeh({}, &coc);
  EXPECT_NEAR(coc, 14.0, 1.0);  // the scene is as intended
  EXPECT_NEAR(std::sqrt(m.polar - kExtraPolar), coc / std::sqrt(2.0), 0.02 * coc);
  for (int k : {3, 5, 6, 7}) EXPECT_LT(std::abs(m.order[k]), 0.02) << k;
}

TEST(Bokeh, BladesGiveTheirPolygonItsCountOrientationAndCircumradius) {
  for (auto [blades, rotation] : {std::pair{6, 20.0}, std::pair{5, 90.0}}) {
    double coc = 0;
    const Moments m = bokeh({blades, rotation, 0.0, 1.0}, &coc);
    // Circumradius from the polar moment: R^2 (1 + 2 cos^2(pi / N)) / 6.
    const double c = std::cos(kPi / blades);
    const double radius = std::sqrt((m.polar - kExtraPolar) * 6.0 / (1.0 + 2.0 * c * c));
    EXPECT_NEAR(radius, coc, std::max(1.0, 0.03 * coc)) << blades;
    // The blade count: the lowest order whose angular moment stands out.
    int count = 0;
    for (int k = 3; k <= 16 && count == 0; ++k)
      if (std::abs(m.order[k]) > 0.02) count = k;
    EXPECT_EQ(count, blades);
    // A corner's angle: the order-N moment's phase over N (modulo a sector).
    const double corner = std::arg(m.order[blades]) / blades * 180.0 / kPi;
    const double sector = 360.0 / blades;
    const double off = std::remainder(corner - rotation, sector);
    EXPECT_NEAR(off, 0.0, 3.0) << blades << " blades: corner at " << corner;
  }
}

TEST(Bokeh, AnamorphicRatioTwoGivesAnOvalTwiceAsTallAsWide) {
  double coc = 0;
  const Moments m = bokeh({0, 0.0, 0.0, 2.0}, &coc);
  const double extra_axis = (kLampPixels * kLampPixels + 1.0) / 12.0;
  // An ellipse's second moment along an axis is a quarter of that semi-axis squared.
  const double tall = std::sqrt(4.0 * (m.yy - extra_axis));
  const double wide = std::sqrt(4.0 * (m.xx - extra_axis));
  EXPECT_NEAR(tall / wide, 2.0, 0.06);
  EXPECT_NEAR(tall, coc, 0.03 * coc);
}

}  // namespace
}  // namespace dofcache::render
