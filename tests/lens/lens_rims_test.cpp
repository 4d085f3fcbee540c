// A real lens's rims fitted as two discs at the stop (lens/lens_rims.h), against the traced lens:
// at every distance from the film centre the discs pass the share of the stop that traced rays
// pass, and cut it where the traced bundle ends.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include <glm/geometric.hpp>

#include "dofcache/core/error.h"
#include "dofcache/lens/lens_rims.h"
#include "dofcache/lens/real_lens.h"

namespace dofcache::lens {
namespace {

MountedLens mount(const std::string& name, double fstop) {
  // The full 36 x 24 mm frame at 3:2, focused at 3 m from the sensor.
  return mount_lens(read_lens_file(name), name, fstop, 3.0, Sensor{}, 300, 200, false);
}

bool inside(const RimDisc& d, double h, glm::dvec2 a) {
  return !d.present() || glm::distance(a, glm::dvec2(d.slope * h, 0.0)) <= d.radius;
}

// What the traced lens passes of the stop, seen from film point (h, 0): rays aimed over a fine
// grid of the exit pupil's plane, those that cross the stop's disc counted, and of those the ones
// every rim passes; with the stop's x-extent of the passing ones.
struct Traced {
  double share = 0, lo = 1, hi = -1;
};
Traced trace_bundle(const RealLens& lens, double h) {
  const CardinalPoints& c = lens.cardinal();
  const double scale = 0.5 * c.exit_pupil_diameter;
  constexpr int kGrid = 160;
  int at_stop = 0, passed = 0;
  Traced t;
  for (int j = 0; j < kGrid; ++j)
    for (int i = 0; i < kGrid; ++i) {
      const double ax = -1.6 + 3.2 * (i + 0.5) / kGrid, ay = -1.6 + 3.2 * (j + 0.5) / kGrid;
      const LensRay ray{{h, 0.0, 0.0},
                        glm::normalize(glm::dvec3{ax * scale - h, ay * scale, c.exit_pupil_z})};
      const auto s = lens.stop_point(ray);
      if (!s || glm::dot(*s, *s) > 1.0) continue;
      ++at_stop;
      if (!lens.passes_rims(ray)) continue;
      ++passed;
      t.lo = std::min(t.lo, s->x), t.hi = std::max(t.hi, s->x);
    }
  t.share = static_cast<double>(passed) / at_stop;
  return t;
}

// The same from the fitted discs: the unit disc's share inside both, and its x-extent on the
// axis row.
Traced model_bundle(const RimModel& m, double h) {
  constexpr int kGrid = 400;
  int disc = 0, passed = 0;
  Traced t;
  for (int j = 0; j < kGrid; ++j)
    for (int i = 0; i < kGrid; ++i) {
      const glm::dvec2 a{-1.0 + 2.0 * (i + 0.5) / kGrid, -1.0 + 2.0 * (j + 0.5) / kGrid};
      if (glm::dot(a, a) > 1.0) continue;
      ++disc;
      if (!inside(m.front, h, a) || !inside(m.rear, h, a)) continue;
      ++passed;
      t.lo = std::min(t.lo, a.x), t.hi = std::max(t.hi, a.x);
    }
  t.share = static_cast<double>(passed) / disc;
  return t;
}

TEST(LensRims, TheFittedDiscsPassWhatTheTracedLensPasses) {
  struct Case {
    const char* lens;
    double fstop;
    double corner_share;  // what the traced lens passes at the corner (the test sees the rims)
  };
  // Measured: 0.22, 0.58 and 1 (the telephoto's bundle fills its stop across the frame).
  for (const Case& c : {Case{"double_gauss_50mm", 0.0, 0.22}, Case{"wide_28mm", 0.0, 0.58},
                        Case{"telephoto_250mm", 0.0, 1.0}}) {
    SCOPED_TRACE(c.lens);
    const MountedLens m = mount(c.lens, c.fstop);
    const double corner = 0.5 * std::hypot(m.film_size.x, m.film_size.y);
    for (double f : {0.0, 0.25, 0.5, 0.75, 1.0}) {
      SCOPED_TRACE(f);
      const double h = f * corner;
      const Traced traced = trace_bundle(*m.lens, h);
      const Traced model = model_bundle(m.lens->rims(), h);
      EXPECT_NEAR(model.share, traced.share, 0.05);
      EXPECT_NEAR(model.lo, traced.lo, 0.06);
      EXPECT_NEAR(model.hi, traced.hi, 0.06);
      if (f == 1.0) {
        EXPECT_NEAR(traced.share, c.corner_share, 0.01);
      }
    }
  }
}

TEST(LensRims, FrontRimsCutTheFarSideAndRearRimsTheNear) {
  // The double Gauss wide open vignettes from both sides at the corner: its front elements clip
  // the side of the stop away from the film point, its rear ones the side towards it.
  const MountedLens m = mount("double_gauss_50mm", 0.0);
  ASSERT_TRUE(m.lens->rims().front.present());
  ASSERT_TRUE(m.lens->rims().rear.present());
  EXPECT_GT(m.lens->rims().front.slope, 0.0);
  EXPECT_LT(m.lens->rims().rear.slope, 0.0);
  // The telephoto's rims cut nothing within the frame: its equivalent stays plain.
  const MountedLens tele = mount("telephoto_250mm", 0.0);
  EXPECT_FALSE(tele.lens->rims().front.present());
  EXPECT_FALSE(tele.lens->rims().rear.present());
  EXPECT_TRUE(tele.equivalent().aperture.plain());
  // Stopped down to f/8 the stop's small disc passes the rims' bundle whole out to mid-frame.
  const MountedLens stopped = mount("double_gauss_50mm", 8.0);
  const double mid = 0.25 * std::hypot(stopped.film_size.x, stopped.film_size.y);
  EXPECT_NEAR(trace_bundle(*stopped.lens, mid).share, 1.0, 1e-9);
  EXPECT_NEAR(model_bundle(stopped.lens->rims(), mid).share, 1.0, 1e-9);
}

TEST(LensRims, TheEquivalentCarriesThemAsItsStops) {
  const MountedLens m = mount("double_gauss_50mm", 0.0);
  const ThinLens thin = m.equivalent();
  EXPECT_TRUE(thin.aperture.rims.any());
  EXPECT_TRUE(thin.aperture.rims.normalised);  // the exposure does not follow the lens
  EXPECT_FALSE(thin.aperture.plain());
  EXPECT_NO_THROW(thin.validate());
  // Mounted again with the equivalent's shape (as the viewer does), the lens is the same one and
  // its rims are its own, not taken as a vignetting stop.
  const MountedLens again = mount_lens(read_lens_file("double_gauss_50mm"), "double_gauss_50mm",
                                       0.0, 3.0, Sensor{}, 300, 200, false, thin.aperture);
  EXPECT_EQ(again.lens, m.lens);
  EXPECT_EQ(again.equivalent(), thin);
  const MountedLens follows = mount_lens(read_lens_file("double_gauss_50mm"), "double_gauss_50mm",
                                         0.0, 3.0, Sensor{}, 300, 200, true);
  EXPECT_FALSE(follows.equivalent().aperture.rims.normalised);
}

TEST(LensRims, AbsurdRimsAreRefused) {
  ApertureShape a;
  a.rims.front = {-0.01, 0.02};
  EXPECT_THROW(a.validate(), Error);
  a.rims.front = {0.01, 0.02};
  a.rims.rear = {0.01, std::nan("")};
  EXPECT_THROW(a.validate(), Error);
  a.rims.rear = {0.01, 0.03};
  EXPECT_NO_THROW(a.validate());
  a.stop = {0.01, 0.1};
  EXPECT_THROW(a.validate(), Error);  // a vignetting stop and rims exclude each other
}

}  // namespace
}  // namespace dofcache::lens
