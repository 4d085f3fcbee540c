// The aperture's shapes against their geometry: the rim of a regular polygon (corners on the unit
// circle, edges at cos(pi / N)), roundness and the anamorphic squeeze; samples uniform over the
// area (fractions of points in a disc and in a wedge against the areas computed by hand); the
// round aperture's samples are the concentric mapping's, bit for bit.
#include "dofcache/lens/aperture.h"

#include <gtest/gtest.h>

#include <glm/geometric.hpp>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "dofcache/core/error.h"
#include "dofcache/image/image_io.h"
#include "dofcache/lens/thin_lens.h"

namespace dofcache::lens {
namespace {

constexpr double kPi = 3.14159265358979323846;
double deg(double d) { return d * kPi / 180.0; }

// `im` written as an EXR in the temporary directory (the caller removes it); its path.
std::string write_temporary(const image::Image& im, const std::string& tag) {
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("dofcache_aperture_" + tag + "_" + std::to_string(::getpid()) + ".exr"))
                               .string();
  image::write_image(path, im);
  return path;
}

// Points for a k x k grid of stratified u (cell centres jittered by a fixed pattern).
template <class F>
void for_grid(int k, const F& f) {
  for (int i = 0; i < k; ++i)
    for (int j = 0; j < k; ++j) {
      const float jx = 0.5f + 0.3f * std::sin(1.7f * (i * k + j));
      const float jy = 0.5f + 0.3f * std::cos(2.3f * (i * k + j));
      f(glm::vec2((i + jx) / k, (j + jy) / k));
    }
}

TEST(Aperture, RoundIsTheConcentricMappingExactly) {
  const Aperture round;
  for_grid(16, [&](glm::vec2 u) {
    const glm::vec2 a = round.sample(u), b = concentric_disk(u);
    EXPECT_EQ(a.x, b.x);
    EXPECT_EQ(a.y, b.y);
  });
  EXPECT_TRUE(ApertureShape{}.round());
  EXPECT_DOUBLE_EQ(ApertureShape{}.inner_scale(), 1.0);
}

TEST(Aperture, PolygonRimHasCornersOnTheCircleAndEdgesAtTheInradius) {
  // Six blades, a corner at 30 degrees: corners at 30, 90, ...; edge normals at 0, 60, ...
  const Aperture hex(ApertureShape{6, 30.0, 0.0, 1.0, {}});
  EXPECT_NEAR(hex.rim(deg(30)), 1.0, 1e-9);
  EXPECT_NEAR(hex.rim(deg(90)), 1.0, 1e-9);
  EXPECT_NEAR(hex.rim(deg(0)), std::cos(kPi / 6), 1e-9);
  EXPECT_NEAR(hex.rim(deg(-60)), std::cos(kPi / 6), 1e-9);
  // Along an edge, from its normal by 15 degrees: the inradius over cos 15.
  EXPECT_NEAR(hex.rim(deg(75)), std::cos(kPi / 6) / std::cos(deg(15)), 1e-9);
  EXPECT_NEAR(ApertureShape({6, 30.0, 0.0, 1.0, {}}).inner_scale(), std::cos(kPi / 6), 1e-12);
  // Half round: halfway between the edge and the circle.
  const Aperture soft(ApertureShape{6, 30.0, 0.5, 1.0, {}});
  EXPECT_NEAR(soft.rim(deg(0)), 0.5 * std::cos(kPi / 6) + 0.5, 1e-9);
  EXPECT_NEAR(soft.rim(deg(30)), 1.0, 1e-9);
  const Aperture full(ApertureShape{6, 30.0, 1.0, 1.0, {}});
  EXPECT_NEAR(full.rim(deg(17)), 1.0, 1e-9);
}

TEST(Aperture, PolygonSamplesAreUniformOverItsArea) {
  // A pentagon, a corner at 10 degrees. Area (N / 2) sin(2 pi / N).
  const int n = 5;
  const Aperture pent(ApertureShape{n, 10.0, 0.0, 1.0, {}});
  const double area = 0.5 * n * std::sin(2 * kPi / n);
  int total = 0, in_disc = 0, in_wedge = 0, outside = 0;
  const double normal = deg(10) + kPi / n;  // an edge's normal
  for_grid(400, [&](glm::vec2 u) {
    const glm::vec2 p = pent.sample(u);
    ++total;
    if (!pent.contains(p * 0.99999f)) ++outside;
    const double r = std::hypot(p.x, p.y);
    if (r < 0.5) ++in_disc;  // the disc of radius 0.5 lies inside (inradius cos 36 = 0.81)
    double a = std::atan2(p.y, p.x) - normal;
    a = std::remainder(a, 2 * kPi);
    if (a >= 0 && a < deg(20)) ++in_wedge;  // from the normal 20 degrees towards a corner
  });
  EXPECT_EQ(outside, 0);
  // Standard errors about 0.0012 and 0.0005 with 160000 points.
  EXPECT_NEAR(double(in_disc) / total, kPi * 0.25 / area, 0.005);
  // The wedge's area: the integral of (inradius / cos t)^2 / 2 over [0, 20 deg].
  const double wedge = 0.5 * std::pow(std::cos(kPi / n), 2) * std::tan(deg(20));
  EXPECT_NEAR(double(in_wedge) / total, wedge / area, 0.002);
}

// Stratified lens samples stay stratified on a polygon: the image of each cell of a 16x16 grid
// over the square is compact, its diameter at most 2.8 times the side of a square of its area
// (the polygon's over 256). Entering the fan through the concentric mapping gives 2.42 here;
// the turn from u.x and the distance from sqrt(u.y) gave wedges 3.77 times as long at the rim.
TEST(Aperture, PolygonStrataStayCompact) {
  const int n = 6, k = 16;
  const Aperture hexagon(ApertureShape{n, 20.0, 0.0, 1.0, {}});
  const double side = std::sqrt(0.5 * n * std::sin(2 * kPi / n) / (k * k));
  double worst = 0.0;
  for (int i = 0; i < k; ++i)
    for (int j = 0; j < k; ++j) {
      std::vector<glm::vec2> points;  // a 5x5 lattice over the cell, its far edges just inside
      for (int a = 0; a <= 4; ++a)
        for (int b = 0; b <= 4; ++b)
          points.push_back(hexagon.sample(
              {std::min((i + a / 4.0f) / k, 0.999999f), std::min((j + b / 4.0f) / k, 0.999999f)}));
      for (const glm::vec2& p : points)
        for (const glm::vec2& q : points) worst = std::max(worst, double(glm::length(p - q)));
    }
  EXPECT_LT(worst / side, 2.8);
  EXPECT_GT(worst / side, 2.0);  // no cell can be smaller than its area allows
}

// An aperture image of 5x4 pixels with black rows and columns and uneven weights: every sample
// lands in a lit pixel, in proportion to its transmission (counted per pixel against the weights
// written here), and two apertures naming the file share one reading of it.
TEST(Aperture, ImageSamplesFollowTheTransmissionPixelByPixel) {
  const float weights[4][5] = {{0, 0, 0, 0, 0}, {1, 0, 3, 0.5f, 0}, {0, 0, 0, 0, 0}, {2, 0, 0, 0, 4}};
  image::Image im(5, 4, 3, 0.0f);
  double total = 0;
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 5; ++x) {
      for (int k = 0; k < 3; ++k) im.at(x, y, k) = weights[y][x];
      total += weights[y][x];
    }
  const std::string path = write_temporary(im, "test");
  ApertureShape shape;
  shape.image = path;
  const Aperture a(shape), b(shape);
  int counts[4][5] = {}, n = 0;
  for_grid(300, [&](glm::vec2 u) {
    const glm::vec2 p = a.sample(u);
    const int x = static_cast<int>(std::floor((p.x + 1.0f) * 2.5f));
    const int y = static_cast<int>(std::floor((1.0f - p.y) * 2.0f));
    ASSERT_TRUE(x >= 0 && x < 5 && y >= 0 && y < 4) << p.x << ", " << p.y;
    ++counts[y][x], ++n;
    EXPECT_EQ(b.sample(u), p);  // the same tables
  });
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 5; ++x)
      EXPECT_NEAR(counts[y][x] / double(n), weights[y][x] / total, 0.002) << x << ", " << y;
  std::filesystem::remove(path);
}

// A larger image with wide dark gaps, a pixel a thousand times brighter than the rest (whose
// neighbours' shares are then too thin for the guide's fixed steps) and uneven greys: every
// sample lands in the pixel that inverting the image's cumulative sums (in double, here) gives
// for its u (so in proportion to the transmission: a row by u.y, a column of it by u.x), and
// the sampling is a monotone warp, so that stratified u stay stratified over the aperture. Then
// the same without the bright pixel (the guide's fixed steps) and in black and white.
TEST(Aperture, ImageSamplingIsAMonotoneWarpInProportionToTheTransmission) {
  for (const int kind : {0, 1, 2}) {
    const bool grey = kind < 2;
    const int w = 37, h = 23;
    image::Image im(w, h, 3, 0.0f);
    std::vector<double> weight(w * h, 0.0), row_sum(h, 0.0);
    double total = 0;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const bool dark = (x >= 8 && x < 25) || y % 5 == 2;
        double v = dark ? 0.0 : grey ? 0.05 + std::fmod(0.618 * (x * 31 + y * 17), 1.0) : 1.0;
        if (kind == 0 && x == 30 && y == 10) v = 1000.0;
        weight[y * w + x] = v, row_sum[y] += v, total += v;
        for (int k = 0; k < 3; ++k) im.at(x, y, k) = static_cast<float>(v);
      }
    const std::string path = write_temporary(im, "warp");
    ApertureShape shape;
    shape.image = path;
    const Aperture a(shape);
    std::filesystem::remove(path);
    // The pixel u falls in: the first row whose cumulative share passes u.y, and in it the first
    // column whose cumulative share passes u.x.
    auto expected = [&](double ux, double uy) {
      int y = 0;
      for (double c = row_sum[0] / total; c <= uy && y < h - 1;) c += row_sum[++y] / total;
      int x = 0;
      for (double c = weight[y * w] / row_sum[y]; c <= ux && x < w - 1;)
        c += weight[y * w + ++x] / row_sum[y];
      return y * w + x;
    };
    const int k = 400;
    int n = 0, elsewhere = 0, out_of_order = 0;
    double bright = 0;
    for (int i = 0; i < k; ++i) {
      float last_x = -2.0f;
      const float uy = (i + 0.37f) / k;
      for (int j = 0; j < k; ++j) {
        const float ux = (j + 0.61f) / k;
        const glm::vec2 p = a.sample(glm::vec2(ux, uy));
        const int x = static_cast<int>(std::floor((p.x + 1.0f) * 0.5f * w));
        const int y = static_cast<int>(std::floor((1.0f - p.y) * 0.5f * h));
        ASSERT_TRUE(x >= 0 && x < w && y >= 0 && y < h) << p.x << ", " << p.y;
        ASSERT_GT(weight[y * w + x], 0.0) << x << ", " << y;
        ++n;
        elsewhere += expected(ux, uy) != y * w + x;
        bright += (x == 30 && y == 10);
        if (p.x < last_x) ++out_of_order;
        last_x = p.x;
      }
      if (i > 0) {  // rows go down the image as u.y grows
        EXPECT_GE(a.sample(glm::vec2(0.5f, (i - 0.63f) / k)).y, a.sample(glm::vec2(0.5f, uy)).y);
      }
    }
    EXPECT_EQ(out_of_order, 0) << "image " << kind;
    // Only where float and double round a boundary differently.
    EXPECT_LE(elsewhere, n / 1000) << "image " << kind;
    if (kind == 0) {
      EXPECT_NEAR(bright / n, 1000.0 / total, 0.003);
    }
  }
}

TEST(Aperture, RoundedBladeSamplesAreUniformOverTheirArea) {
  // Six blades, roundness 0.5: the rim at t from an edge's normal is 0.5 cos 30 / cos t + 0.5.
  // Its area, 12 half-sectors of the integral of rim^2 / 2, by the midpoint rule here.
  const Aperture soft(ApertureShape{6, 15.0, 0.5, 1.0, {}});
  double area = 0;
  const int steps = 100000;
  for (int i = 0; i < steps; ++i) {
    const double t = (i + 0.5) / steps * kPi / 6;
    const double r = 0.5 * std::cos(kPi / 6) / std::cos(t) + 0.5;
    area += 12 * 0.5 * r * r * (kPi / 6) / steps;
  }
  int total = 0, in_disc = 0, in_ring = 0, outside = 0;
  for_grid(400, [&](glm::vec2 u) {
    const glm::vec2 p = soft.sample(u);
    ++total;
    if (!soft.contains(p * 0.99999f)) ++outside;
    const double r = std::hypot(p.x, p.y);
    in_disc += r < 0.5;
    in_ring += r >= 0.9;  // beyond the inradius 0.933 only near the corners: area by rule
  });
  EXPECT_EQ(outside, 0);
  EXPECT_NEAR(double(in_disc) / total, kPi * 0.25 / area, 0.005);
  // Outside radius 0.9: the area less the disc of 0.9, since the rim is beyond 0.9 everywhere.
  EXPECT_NEAR(double(in_ring) / total, (area - kPi * 0.81) / area, 0.003);
}

TEST(Aperture, AnamorphicRatioSqueezesTheWidth) {
  // Ratio 2: twice as tall as wide, the height kept at the round aperture's.
  const Aperture oval(ApertureShape{0, 0.0, 0.0, 2.0, {}});
  EXPECT_NEAR(oval.rim(0.0), 0.5, 1e-6);
  EXPECT_NEAR(oval.rim(kPi / 2), 1.0, 1e-6);
  float max_x = 0, max_y = 0;
  for_grid(100, [&](glm::vec2 u) {
    const glm::vec2 p = oval.sample(u);
    max_x = std::max(max_x, std::abs(p.x));
    max_y = std::max(max_y, std::abs(p.y));
    EXPECT_TRUE(oval.contains(p * 0.9999f));
  });
  EXPECT_NEAR(max_y / max_x, 2.0, 0.03);
  EXPECT_NEAR(ApertureShape({0, 0.0, 0.0, 2.0, {}}).inner_scale(), 0.5, 1e-12);
  EXPECT_NEAR(ApertureShape({0, 0.0, 0.0, 0.5, {}}).inner_scale(), 0.5, 1e-12);  // wide ovals
  EXPECT_NEAR(ApertureShape({6, 0.0, 0.0, 2.0, {}}).inner_scale(), 0.5 * std::cos(kPi / 6), 1e-12);
  // The cache's oval footprint: the larger semi-axis (the polygon's inradius) and the squeeze.
  EXPECT_NEAR(ApertureShape({6, 0.0, 0.0, 2.0, {}}).footprint_scale(), std::cos(kPi / 6), 1e-12);
  EXPECT_EQ(ApertureShape({0, 0.0, 0.0, 2.0, {}}).footprint_squeeze(), glm::dvec2(0.5, 1.0));
  EXPECT_EQ(ApertureShape({0, 0.0, 0.0, 0.25, {}}).footprint_squeeze(), glm::dvec2(1.0, 0.25));
  EXPECT_EQ(ApertureShape{}.footprint_squeeze(), glm::dvec2(1.0, 1.0));
  const Aperture wide(ApertureShape{0, 0.0, 0.0, 0.5, {}});
  EXPECT_NEAR(wide.rim(0.0), 1.0, 1e-6);
  EXPECT_NEAR(wide.rim(kPi / 2), 0.5, 1e-6);
}

TEST(Aperture, AbsurdShapesAreRefused) {
  for (int blades : {1, 2, -3, 17}) EXPECT_THROW((ApertureShape{blades, 0, 0, 1, {}}.validate()), Error);
  for (double r : {-0.1, 1.1, double(NAN)}) EXPECT_THROW((ApertureShape{6, 0, r, 1, {}}.validate()), Error);
  for (double q : {0.0, -1.0, double(NAN), double(INFINITY), 1000.0})
    EXPECT_THROW((ApertureShape{6, 0, 0, q, {}}.validate()), Error);
  EXPECT_THROW((ApertureShape{6, INFINITY, 0, 1, {}}.validate()), Error);
  EXPECT_NO_THROW((ApertureShape{16, -720.0, 1.0, 0.01, {}}.validate()));
  // A vignetting stop needs a positive, finite radius and distance (metres).
  for (VignettingStop stop : {VignettingStop{0.0, 0.02}, VignettingStop{0.01, 0.0},
                              VignettingStop{-0.01, 0.02}, VignettingStop{0.01, double(NAN)},
                              VignettingStop{double(INFINITY), 0.02}})
    EXPECT_THROW((ApertureShape{0, 0, 0, 1, stop}.validate()), Error);
  EXPECT_NO_THROW((ApertureShape{0, 0, 0, 1, {0.01, 0.02}}.validate()));
  EXPECT_TRUE((ApertureShape{0, 0, 0, 1, {0.01, 0.02}}.round()));
  EXPECT_FALSE((ApertureShape{0, 0, 0, 1, {0.01, 0.02}}.plain()));
  // Chromatic aberration: finite, a lateral one within 20 %, and every band's focus beyond the
  // focal length.
  for (auto [axial, lateral] : {std::pair{double(NAN), 0.0}, std::pair{0.0, 0.3},
                                std::pair{0.0, -0.25}, std::pair{0.0, double(INFINITY)}})
    EXPECT_THROW((ApertureShape{0, 0, 0, 1, {}, axial, lateral}.validate()), Error);
  EXPECT_NO_THROW((ApertureShape{0, 0, 0, 1, {}, -0.1, 0.02}.validate()));
  EXPECT_FALSE((ApertureShape{0, 0, 0, 1, {}, 0.0, 0.01}.plain()));
  ThinLens near{0.05, 2.0, 0.5};
  near.aperture.axial_ca = 0.9;  // blue in focus at 0.05 m: at the focal length
  EXPECT_THROW(near.validate(), Error);
  near.aperture.axial_ca = 0.8;
  EXPECT_NO_THROW(near.validate());
  // A profile's strength lies in [0, 1]; its weights average 1 over the shape (rho has the
  // density 2 rho): the centre-weighted T = 1 - s rho^2 over 1 - s / 2.
  for (double s : {-0.1, 1.5, double(NAN)})
    EXPECT_THROW((ApertureShape{0, 0, 0, 1, {}, 0, 0, ApertureProfile::Rim, s}.validate()), Error);
  const ApertureShape centre{0, 0, 0, 1, {}, 0, 0, ApertureProfile::Centre, 0.8};
  EXPECT_NEAR(centre.transmission(0.0), 1.0 / 0.6, 1e-12);
  EXPECT_NEAR(centre.transmission(1.0), 0.2 / 0.6, 1e-12);
  double mean = 0;
  for (int i = 0; i < 100000; ++i) {
    const double rho = (i + 0.5) / 100000;
    mean += centre.transmission(rho) * 2 * rho / 100000;
  }
  EXPECT_NEAR(mean, 1.0, 1e-6);
  EXPECT_EQ(parse_aperture_profile("rim"), ApertureProfile::Rim);
  EXPECT_THROW(parse_aperture_profile("bubble"), Error);
  EXPECT_FALSE(centre.plain());
  // The lens checks its aperture too.
  ThinLens lens;
  lens.aperture.blades = 2;
  EXPECT_THROW(lens.validate(), Error);
}

TEST(Aperture, ChoicesFallBackValueByValue) {
  ApertureChoices cli, extras;
  cli.blades = 6;
  extras.blades = 5;
  extras.anamorphic_ratio = 1.5;
  const ApertureShape s = cli.over(extras).shape();
  EXPECT_EQ(s.blades, 6);
  EXPECT_DOUBLE_EQ(s.anamorphic_ratio, 1.5);
  EXPECT_DOUBLE_EQ(s.roundness, 0.0);
  EXPECT_TRUE(ApertureChoices{}.shape().round());
  // Every value falls back, the newer ones too.
  ApertureChoices more;
  more.vignetting_stop = VignettingStop{0.01, 0.02};
  more.axial_ca = 0.1;
  more.lateral_ca = 0.01;
  more.profile = ApertureProfile::Rim;
  more.profile_strength = 0.5;
  more.lens_tilt = std::pair{1.0, 2.0};
  more.lens_shift = std::pair{0.1, 0.2};
  more.image = "a.png";
  const ApertureShape m = ApertureChoices{}.over(more).shape();
  EXPECT_EQ(m.stop, (VignettingStop{0.01, 0.02}));
  EXPECT_EQ(m.axial_ca, 0.1);
  EXPECT_EQ(m.lateral_ca, 0.01);
  EXPECT_EQ(m.profile, ApertureProfile::Rim);
  EXPECT_EQ(m.profile_strength, 0.5);
  EXPECT_EQ(m.tilt_y_deg, 2.0);
  EXPECT_EQ(m.shift_x, 0.1);
  EXPECT_EQ(m.image, "a.png");
  // A resolved shape as choices gives the same shape back.
  EXPECT_EQ(ApertureChoices::of(m).shape(), m);
  const ApertureShape plain_round;
  EXPECT_FALSE(ApertureChoices::of(plain_round).vignetting_stop.has_value());
  EXPECT_EQ(ApertureChoices::of(plain_round).shape(), plain_round);
}

}  // namespace
}  // namespace dofcache::lens
