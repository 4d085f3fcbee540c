// Every thin-lens formula (paper eqs. (2.1)-(2.6)) against values computed by hand.
#include "dofcache/lens/thin_lens.h"

#include <gtest/gtest.h>

#include <cmath>

#include <glm/geometric.hpp>

#include "dofcache/core/error.h"

namespace dofcache::lens {
namespace {

// F = 50 mm, n = 2, P = 2 m, D = 4 m throughout (hand-computed below).
constexpr double F = 0.05, N = 2.0, P = 2.0, D = 4.0;

TEST(ThinLens, ThinLensLawEq2_1) {
  // 1/F = 1/R1 + 1/R2 with R1 = 2 m, R2 = 2/39 m: 1/2 + 39/2 = 20 -> F = 0.05 m.
  EXPECT_NEAR(focal_length_from_distances(2.0, 2.0 / 39.0), 0.05, 1e-12);
}

TEST(ThinLens, ImageDistanceEq2_2And2_3) {
  // V_P = 0.05*2/1.95 = 0.0512820513; V_D = 0.05*4/3.95 = 0.0506329114.
  EXPECT_NEAR(image_distance(F, P), 0.0512820513, 1e-10);
  EXPECT_NEAR(image_distance(F, D), 0.0506329114, 1e-10);
  // Consistent with eq. (2.1): a point at P images at V_P.
  EXPECT_NEAR(focal_length_from_distances(P, image_distance(F, P)), F, 1e-12);
}

TEST(ThinLens, CocDiameterEq2_4) {
  // C = |V_D - V_P| F / (n V_D) = 0.00064913992 * 0.05 / (2 * 0.0506329114) = 0.000320513 m.
  EXPECT_NEAR(coc_diameter(F, N, P, D), 3.20513e-4, 1e-9);
  EXPECT_DOUBLE_EQ(coc_diameter(F, N, P, P), 0.0);  // in focus
}

TEST(ThinLens, ConeRadiusEq2_5) {
  // r = 0.5 * 0.025 * |4 - 2| / 2 = 0.0125 m.
  EXPECT_NEAR(cone_radius(F, N, P, D), 0.0125, 1e-12);
  // In front of the focal plane: D = 1 m -> 0.5 * 0.025 * 1 / 2 = 0.00625 m.
  EXPECT_NEAR(cone_radius(F, N, P, 1.0), 0.00625, 1e-12);
}

TEST(ThinLens, ProjectedConeRadiusEq2_6) {
  // R = r V_P / D = 0.0125 * 0.0512820513 / 4 = 0.000160256 m.
  EXPECT_NEAR(projected_cone_radius(F, N, P, D), 1.60256e-4, 1e-9);
}

TEST(ThinLens, ProjectedRadiusIsHalfTheCocSection2_2) {
  for (double depth : {0.3, 0.9, 1.5, 2.0, 2.5, 4.0, 10.0, 100.0})
    for (double n : {1.4, 2.8, 16.0})
      EXPECT_NEAR(projected_cone_radius(F, n, P, depth), 0.5 * coc_diameter(F, n, P, depth), 1e-12)
          << "depth " << depth << " f/" << n;
}

TEST(ThinLens, ImagingInPixels) {
  // yfov = 2 atan(0.5): film height = V_P; 100 pixels tall -> pitch = V_P / 100.
  LensImaging im{ThinLens{F, N, P}, 2.0 * std::atan(0.5), 100};
  double v_p = image_distance(F, P);
  EXPECT_NEAR(im.pixel_pitch(), v_p / 100.0, 1e-15);
  // Footprint at depth 4 m: pitch * D / V_P = 0.04 m (eq. (4.1)).
  EXPECT_NEAR(im.pixel_footprint(4.0), 0.04, 1e-12);
  // CoC at 4 m: 3.20513e-4 / (5.12820513e-4) = 0.625 px, signed positive behind focus.
  EXPECT_NEAR(im.signed_coc_pixels(4.0), 0.625, 1e-5);
  EXPECT_NEAR(im.signed_coc_pixels(1.0), -im.coc_radius_pixels(1.0) * 2.0, 1e-12);
  for (double depth : {0.5, 1.0, 3.0, 4.0, 50.0})
    EXPECT_NEAR(im.depth_for_signed_coc(im.signed_coc_pixels(depth)), depth, 1e-9 * depth);
}

TEST(ThinLens, ValidateRejectsAbsurdValues) {
  EXPECT_NO_THROW((ThinLens{F, N, P}.validate()));
  EXPECT_THROW((ThinLens{-0.05, N, P}.validate()), Error);
  EXPECT_THROW((ThinLens{F, 0.0, P}.validate()), Error);
  EXPECT_THROW((ThinLens{F, N, NAN}.validate()), Error);
  EXPECT_THROW((ThinLens{F, N, 0.04}.validate()), Error);  // focus inside the focal length
  EXPECT_THROW((ThinLens{50.0, N, P}.validate()), Error);  // millimetres given as metres
}

TEST(ConcentricDisk, MapsSquareIntoDiskPreservingArea) {
  EXPECT_FLOAT_EQ(glm::length(concentric_disk({1.0f, 0.5f})), 1.0f);  // edge -> rim
  EXPECT_FLOAT_EQ(glm::length(concentric_disk({0.5f, 0.5f})), 0.0f);  // centre -> centre
  // Area preservation: the fraction of a uniform grid landing within radius 0.5 is 1/4.
  int inside = 0, n = 200;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      glm::vec2 d = concentric_disk({(i + 0.5f) / n, (j + 0.5f) / n});
      EXPECT_LE(glm::length(d), 1.0f + 1e-6f);
      inside += glm::length(d) < 0.5f;
    }
  EXPECT_NEAR(inside / double(n * n), 0.25, 0.01);
}

TEST(ConcentricDisk, PolarFormIsTheSameMapping) {
  // By hand: the square's edge midpoints and a corner go to the rim at 0, 1/4, 1/2, 3/4 and
  // 1/8 of a turn; the centre to the centre.
  const struct {
    glm::vec2 u;
    float radius, turn;
  } cases[] = {{{1.0f, 0.5f}, 1.0f, 0.0f},   {{0.5f, 1.0f}, 1.0f, 0.25f},
               {{0.0f, 0.5f}, 1.0f, 0.5f},   {{0.5f, 0.0f}, 1.0f, 0.75f},
               {{1.0f, 1.0f}, 1.0f, 0.125f}, {{0.5f, 0.5f}, 0.0f, 0.0f},
               {{0.75f, 0.625f}, 0.5f, 0.0625f}};
  for (const auto& c : cases) {
    const DiskPolar d = concentric_polar(c.u);
    EXPECT_FLOAT_EQ(d.radius, c.radius) << c.u.x << ", " << c.u.y;
    EXPECT_FLOAT_EQ(d.turn, c.turn) << c.u.x << ", " << c.u.y;
  }
  // Everywhere else: the point concentric_disk gives, with the turn in [0, 1).
  const int n = 97;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const glm::vec2 u((i + 0.37f) / n, (j + 0.71f) / n);
      const DiskPolar d = concentric_polar(u);
      ASSERT_GE(d.turn, 0.0f);
      ASSERT_LT(d.turn, 1.0f);
      const float a = 2.0f * 3.14159265f * d.turn;
      const glm::vec2 expected = concentric_disk(u);
      EXPECT_NEAR(d.radius * std::cos(a), expected.x, 2e-6f);
      EXPECT_NEAR(d.radius * std::sin(a), expected.y, 2e-6f);
    }
}

}  // namespace
}  // namespace dofcache::lens

namespace dofcache::lens {
namespace {

// The plane z / 2 - 2 y + x = 1 (camera space): P = 2 m, sin(tilt_x) / F = 2 and sin(tilt_y) / F
// = -1 per metre, so at F = 50 mm tilt_x = asin(0.1) = 5.7392 and tilt_y = asin(-0.05) =
// -2.8660 degrees. Three of its points, worked by hand.
TEST(FocusPlaneThrough, SolvesTheTiltedPlaneThroughThreePoints) {
  const glm::dvec3 points[3] = {{0.0, 0.5, 4.0}, {-1.0, 0.0, 4.0}, {0.3, -0.2, 0.6}};
  const TiltedFocus f = focus_plane_through(points, 0.05);
  EXPECT_NEAR(f.focus_distance, 2.0, 1e-12);
  EXPECT_NEAR(f.tilt_x_deg, 5.7392, 1e-4);
  EXPECT_NEAR(f.tilt_y_deg, -2.8660, 1e-4);
  // An untilted plane: three points at one depth.
  const glm::dvec3 flat[3] = {{0.1, 0.0, 3.0}, {-0.4, 0.2, 3.0}, {0.0, -0.3, 3.0}};
  const TiltedFocus g = focus_plane_through(flat, 0.05);
  EXPECT_NEAR(g.focus_distance, 3.0, 1e-12);
  EXPECT_NEAR(g.tilt_x_deg, 0.0, 1e-9);
  EXPECT_NEAR(g.tilt_y_deg, 0.0, 1e-9);
}

TEST(FocusPlaneThrough, PointsWithoutOneUsablePlaneAreOneLineErrors) {
  auto message = [](const glm::dvec3 (&p)[3]) {
    try {
      focus_plane_through(p, 0.05);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  const glm::dvec3 line[3] = {{0.0, 0.0, 1.0}, {0.1, 0.1, 2.0}, {0.2, 0.2, 3.0}};
  EXPECT_NE(message(line).find("one line"), std::string::npos) << message(line);
  const glm::dvec3 through_lens[3] = {{1.0, 0.0, 1.0}, {0.0, 1.0, 1.0}, {1.0, 1.0, 2.0}};
  EXPECT_NE(message(through_lens).find("one line"), std::string::npos);
  const glm::dvec3 near[3] = {{0.001, 0.0, 0.01}, {0.0, 0.001, 0.01}, {-0.001, 0.0, 0.01}};
  EXPECT_NE(message(near).find("within the focal length"), std::string::npos) << message(near);
  const glm::dvec3 steep[3] = {{0.0, 0.0, 2.0}, {0.0, 0.1, 8.0}, {1.0, 0.0, 2.0}};
  EXPECT_NE(message(steep).find("90 degrees"), std::string::npos) << message(steep);
  const glm::dvec3 behind[3] = {{0.0, 0.0, -1.0}, {0.0, 0.1, 8.0}, {1.0, 0.0, 2.0}};
  EXPECT_NE(message(behind).find("ahead of the lens"), std::string::npos);
  for (const std::string& m : {message(line), message(near), message(steep)})
    EXPECT_EQ(m.find('\n'), std::string::npos);
}

}  // namespace
}  // namespace dofcache::lens

namespace dofcache::lens {
namespace {

// The stops' discs a point's lens rays must start in, by hand: a vignetting stop and a real
// lens's front and rear rims, on and off the axis, and none for a point before the stop.
TEST(ThinLens, StopCirclesAreWhereTheStopsPassTheBundle) {
  ThinLens l(0.05, 2.0, 2.0);  // aperture radius 12.5 mm
  ThinLens::StopCircle c[2];
  l.stop_circles({0.3, -0.2}, 5.0, c);
  EXPECT_FALSE(std::isfinite(c[0].radius) || std::isfinite(c[1].radius));
  l.aperture.stop = {0.0125, 0.05};
  // At depth 5, k = (1 - d / D) r = 0.012375: radius R / k = 1.0101, centre -s d / k.
  l.stop_circles({0.1, -0.2}, 5.0, c);
  EXPECT_NEAR(c[0].radius, 0.0125 / 0.012375, 1e-12);
  EXPECT_NEAR(c[0].centre.x, -0.1 * 0.05 / 0.012375, 1e-12);
  EXPECT_NEAR(c[0].centre.y, 0.2 * 0.05 / 0.012375, 1e-12);
  EXPECT_FALSE(std::isfinite(c[1].radius));
  l.stop_circles({0.1, 0.0}, 0.04, c);  // before the stop's plane
  EXPECT_FALSE(std::isfinite(c[0].radius));
  // Rims: the rear one behind the lens at 20 mm, before the image at V_3 = 0.05 x 3 / 2.95:
  // k = (1 - 0.02 / V_3) r, centre +s d / k (the other side).
  l.aperture.stop = {};
  l.aperture.rims.front = {0.011, 0.03};
  l.aperture.rims.rear = {0.010, 0.02};
  l.stop_circles({0.0, 0.3}, 3.0, c);
  EXPECT_NEAR(c[0].radius, 0.011 / 0.012375, 1e-12);
  EXPECT_NEAR(c[0].centre.y, -0.3 * 0.03 / 0.012375, 1e-12);
  const double k = (1.0 - 0.02 / (0.05 * 3.0 / 2.95)) * 0.0125;
  EXPECT_NEAR(c[1].radius, 0.010 / k, 1e-9);
  EXPECT_NEAR(c[1].centre.y, 0.3 * 0.02 / k, 1e-9);
  EXPECT_EQ(c[1].centre.x, 0.0);
}

}  // namespace
}  // namespace dofcache::lens
