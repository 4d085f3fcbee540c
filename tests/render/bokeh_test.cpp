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
#include <utility>

#include "dofcache/render/camera.h"
#include "dofcache/render/renderer.h"
#include "dofcache/core/error.h"
#include "dofcache/image/image_io.h"
#include "scratch_dir.h"
#include "lamp_bokeh.h"
#include "test_scenes.h"

namespace dofcache::render {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kSize = 48;
constexpr double kDepth = 3.0;  // the lamp; the focus is at 1 m
constexpr double kLampPixels = 1.5;

using Moments = testing::BokehMoments;

// The DRT image of the lamp (lamp_bokeh.h).
image::Image lamp_image(const lens::ThinLens& lens, float yfov, int size, glm::vec3 lamp,
                        double side, int spp) {
  const scene::Scene s = testing::lamp_scene(lamp, side, yfov);
  scene::Accel accel(s);
  return render(s, accel, s.cameras[0], testing::lamp_settings(lens, size, spp)).color;
}

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
  const image::Image color =
      lamp_image(lens, yfov, kSize, {0.0f, 0.0f, -static_cast<float>(kDepth)}, side, 4096);

  return testing::bokeh_moments(color, 1);
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
    const Moments m = bokeh({blades, rotation, 0.0, 1.0, {}}, &coc);
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
  const Moments m = bokeh({0, 0.0, 0.0, 2.0, {}}, &coc);
  const double extra_axis = (kLampPixels * kLampPixels + 1.0) / 12.0;
  // An ellipse's second moment along an axis is a quarter of that semi-axis squared.
  const double tall = std::sqrt(4.0 * (m.yy - extra_axis));
  const double wide = std::sqrt(4.0 * (m.xx - extra_axis));
  EXPECT_NEAR(tall / wide, 2.0, 0.06);
  EXPECT_NEAR(tall, coc, 0.03 * coc);
}

// Optical vignetting. Seen from a point of the focal plane F, the lens rays through a lamp at L
// (depth Z) start at p = (L P / Z - F) Z / (P - Z); they pass the aperture where |p| <= a and a
// stop of radius R at depth D where |p (1 - D / P) + F D / P| <= R. Both are discs in F: centred
// at L P / Z with radius a |P - Z| / Z, and at L (P - D) / (Z - D) with radius R |P - Z| / |Z - D|.
// The bokeh is their intersection (cat's eye): its light, against the same lamp seen without the
// stop, is the intersection's area over the first disc's, and its centroid the intersection's;
// both are computed here on a fine grid, independently of the renderer.
TEST(Bokeh, VignettingStopCutsTheBokehToTheIntersectionOfTwoDiscs) {
  constexpr int kImage = 64;
  const double P = 1.0, Z = 3.0, D = 0.5, a = 0.0125;  // f/2 at 50 mm
  const double R = 1.1 * a * (Z - D) / Z;  // on axis the stop clips nothing (r2 = 1.1 r1)
  const double lx = 0.05 / std::sqrt(2.0), ly = lx;  // the second disc 0.8 r1 from the first
  // Ten pixels of circle-of-confusion radius: r1 = a (Z - P) / Z on the focal plane.
  const double r1 = a * (Z - P) / Z, k = 10.0 / r1;  // pixels per metre on the focal plane
  const float yfov = static_cast<float>(2.0 * std::atan(kImage / (2.0 * P * k)));
  lens::ThinLens plain{0.05, 2.0, P};
  lens::ThinLens stopped = plain;
  stopped.aperture.stop = {R, D};
  const glm::vec3 lamp(static_cast<float>(lx), static_cast<float>(ly), -static_cast<float>(Z));
  const double side = 1.0 / k * Z / P;  // a pixel's footprint at the lamp's depth
  const image::Image open = lamp_image(plain, yfov, kImage, lamp, side, 2048);
  const image::Image cut = lamp_image(stopped, yfov, kImage, lamp, side, 2048);

  // The two discs in pixels (x right, y up from the image centre).
  const double c1x = lx * P / Z * k, c1y = ly * P / Z * k, rad1 = r1 * k;
  const double c2x = lx * (P - D) / (Z - D) * k, c2y = ly * (P - D) / (Z - D) * k;
  const double rad2 = R * (Z - P) / (Z - D) * k;
  double area = 0, mx = 0, my = 0;
  const int n = 1200;  // grid over the first disc's square
  const double cell = 2.0 * rad1 / n;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const double x = c1x - rad1 + (i + 0.5) * cell, y = c1y - rad1 + (j + 0.5) * cell;
      if (std::hypot(x - c1x, y - c1y) <= rad1 && std::hypot(x - c2x, y - c2y) <= rad2)
        area += cell * cell, mx += x * cell * cell, my += y * cell * cell;
    }
  mx /= area, my /= area;
  const double predicted_share = area / (kPi * rad1 * rad1);
  ASSERT_GT(predicted_share, 0.3);  // a cat's eye, not a disc or nothing
  ASSERT_LT(predicted_share, 0.8);

  double e_open = 0, e_cut = 0, cx = 0, cy = 0, outside2 = 0;
  for (int y = 0; y < kImage; ++y)
    for (int x = 0; x < kImage; ++x) {
      const double px = x + 0.5 - kImage / 2.0, py = kImage / 2.0 - (y + 0.5);
      const double v = cut.at(x, y, 1);
      e_open += open.at(x, y, 1), e_cut += v, cx += v * px, cy += v * py;
      if (std::hypot(px - c2x, py - c2y) > rad2 + 1.5) outside2 += v;
    }
  cx /= e_cut, cy /= e_cut;
  EXPECT_NEAR(e_cut / e_open, predicted_share, 0.03 * predicted_share);
  EXPECT_NEAR(cx, mx, 0.3);
  EXPECT_NEAR(cy, my, 0.3);
  // Nothing of the lamp's light lands outside the stop's disc (beyond the lamp's own size).
  EXPECT_LT(outside2 / e_cut, 0.01);
  // On axis the same stop clips nothing: the centre pixel's lens rays all pass.
  ThinLensCamera camera(glm::mat4(1.0f), yfov, stopped, kImage, kImage);
  for (float u : {0.05f, 0.5f, 0.95f})
    for (float v : {0.05f, 0.5f, 0.95f}) {
      EXPECT_EQ(camera.lens_ray({kImage / 2.0f, kImage / 2.0f}, {u, v}).weight, 1.0f);
    }
}

using ChannelMoments = testing::BokehMoments;
ChannelMoments channel_moments(const image::Image& im, int k) { return testing::bokeh_moments(im, k); }

// Axial chromatic aberration M: the red band focuses at P + M / 2, the blue at P - M / 2, on the
// same film. A white lamp at depth Z then images to a red disc of radius a |P_r - Z| / Z on the
// red plane of focus, which the film sees at H / (2 P_r tan(yfov / 2)) pixels per metre, and
// likewise in blue; green keeps the lens's own circle of confusion. The lamp's light is the
// same in every band (a neutral lamp stays neutral).
TEST(Bokeh, AxialChromaticAberrationGivesRedAndBlueDiscsOfTheirOwnRadii) {
  const double P = 1.0, M = 0.2, a = 0.0125;
  lens::ThinLens lens{0.05, 2.0, P};
  lens.aperture.axial_ca = M;
  const float yfov = 0.0286f;
  const lens::LensImaging imaging{lens, yfov, kSize};
  const double side = kLampPixels * imaging.pixel_footprint(kDepth);
  const image::Image im =
      lamp_image(lens, yfov, kSize, {0.0f, 0.0f, -static_cast<float>(kDepth)}, side, 3072);
  const double tan_half = std::tan(0.5 * yfov);
  double totals[3];
  for (int k = 0; k < 3; ++k) {
    const double pc = P + M * lens::ApertureShape::band_position(k);
    const double predicted = a * std::abs(pc - kDepth) / kDepth * kSize / (2.0 * pc * tan_half);
    const ChannelMoments m = channel_moments(im, k);
    // A disc's polar moment is r^2 / 2; the lamp and the pixel add kExtraPolar.
    EXPECT_NEAR(std::sqrt(2.0 * (m.polar - kExtraPolar)), predicted, 0.03 * predicted) << k;
    totals[k] = m.total;
  }
  EXPECT_NEAR(totals[0] / totals[1], 1.0, 0.02);
  EXPECT_NEAR(totals[2] / totals[1], 1.0, 0.02);
}

// Lateral chromatic aberration S: the red band images the scene 1 + S / 2 times as large as
// green, the blue 1 - S / 2 times, about the image centre. A lamp in focus off the axis shows it.
TEST(Bokeh, LateralChromaticAberrationMagnifiesRedOverBlue) {
  const double P = 1.0, S = 0.1;
  lens::ThinLens lens{0.05, 2.0, P};
  lens.aperture.lateral_ca = S;
  const float yfov = 0.0286f;
  const lens::LensImaging imaging{lens, yfov, kSize};
  // 12 pixels right and 8 up of the centre, in focus.
  const double k = kSize / (2.0 * P * std::tan(0.5 * yfov));
  const glm::vec3 lamp(static_cast<float>(12.0 / k), static_cast<float>(8.0 / k),
                       -static_cast<float>(P));
  const image::Image im = lamp_image(lens, yfov, kSize, lamp, imaging.pixel_footprint(P), 96);
  for (int c = 0; c < 3; ++c) {
    const double scale = 1.0 + S * lens::ApertureShape::band_position(c);
    const ChannelMoments m = channel_moments(im, c);
    EXPECT_NEAR(m.cx, 12.0 * scale, 0.15) << c;
    EXPECT_NEAR(m.cy, 8.0 * scale, 0.15) << c;
  }
}

// A transmission profile: the bokeh of a lamp far behind the focus is the aperture scaled, so its
// brightness at a fraction rho of the circle of confusion's radius follows T(rho): 1 - s rho^2
// centre-weighted, 1 - s + s rho^2 rim-weighted (lens/aperture.h). Measured as the mean in
// rings well inside the rim; the lamp's light stays the uniform aperture's (the exposure does not
// change).
TEST(Bokeh, ApertureProfileShapesTheBrightnessAcrossTheDisc) {
  lens::ThinLens lens{0.05, 2.0, 1.0};
  const float yfov = 0.0286f;
  const lens::LensImaging imaging{lens, yfov, kSize};
  const double coc = imaging.coc_radius_pixels(kDepth);
  const double side = kLampPixels * imaging.pixel_footprint(kDepth);
  const glm::vec3 lamp(0.0f, 0.0f, -static_cast<float>(kDepth));
  const image::Image uniform = lamp_image(lens, yfov, kSize, lamp, side, 4096);
  double uniform_total = 0;
  for (float v : uniform.data()) uniform_total += v;
  for (const auto& choice : {std::pair{lens::ApertureProfile::Rim, 1.0},
                             std::pair{lens::ApertureProfile::Centre, 0.8}}) {
    const lens::ApertureProfile profile = choice.first;  // lambdas below capture them
    const double s = choice.second;
    lens.aperture.profile = profile;
    lens.aperture.profile_strength = s;
    const image::Image im = lamp_image(lens, yfov, kSize, lamp, side, 4096);
    // A pixel at rho gathers lens points around rho, spread by the lamp's square and the pixel's
    // box: E|delta|^2 = 2 (side^2 + 1) / 12 px^2, which T's rho^2 meets in the mean.
    const double spread2 = 2.0 * (kLampPixels * kLampPixels + 1.0) / 12.0 / (coc * coc);
    auto transmission = [&](double rho) {
      const double r2 = rho * rho + spread2;
      return profile == lens::ApertureProfile::Centre ? 1.0 - s * r2 : 1.0 - s + s * r2;
    };
    // Brightness in rings [r0, r1) of rho over the uniform aperture's there: the same lens
    // samples meet the lamp in both renders, so their sampling noise cancels.
    auto ring = [&](double r0, double r1) {
      double sum = 0, base = 0;
      for (int y = 0; y < kSize; ++y)
        for (int x = 0; x < kSize; ++x) {
          const double rho = std::hypot(x + 0.5 - kSize / 2.0, y + 0.5 - kSize / 2.0) / coc;
          if (rho >= r0 && rho < r1) sum += im.at(x, y, 1), base += uniform.at(x, y, 1);
        }
      return sum / base;
    };
    // The predicted ring means: T averaged over the ring's area (weight rho).
    auto predicted = [&](double r0, double r1) {
      double num = 0, den = 0;
      for (int i = 0; i < 1000; ++i) {
        const double rho = r0 + (r1 - r0) * (i + 0.5) / 1000;
        num += transmission(rho) * rho, den += rho;
      }
      return num / den;
    };
    const double inner = ring(0.0, 0.35), middle = ring(0.35, 0.6), outer = ring(0.6, 0.8);
    EXPECT_NEAR(outer / inner, predicted(0.6, 0.8) / predicted(0.0, 0.35),
                0.05 * predicted(0.6, 0.8) / predicted(0.0, 0.35))
        << lens::aperture_profile_name(profile);
    EXPECT_NEAR(middle / inner, predicted(0.35, 0.6) / predicted(0.0, 0.35),
                0.05 * predicted(0.35, 0.6) / predicted(0.0, 0.35))
        << lens::aperture_profile_name(profile);
    double total = 0;
    for (float v : im.data()) total += v;
    EXPECT_NEAR(total / uniform_total, 1.0, 0.02) << lens::aperture_profile_name(profile);
  }
}

// Tilt (Scheimpflug): the plane of focus is z / P - y sin(tilt_x) / F - x sin(tilt_y) / F = 1 in
// camera space. A lamp placed on it off the axis images to a point; through the untilted lens
// the same lamp spreads over its circle of confusion a |P - Z| / (P Z) (k pixels per unit slope).
TEST(Bokeh, TiltPutsThePlaneOfFocusWhereScheimpflugPredicts) {
  constexpr int kImage = 64;
  const double F = 0.05, P = 1.0, a = 0.05;  // f/0.5
  const double tilt = std::asin(5.0 * F) * 180.0 / kPi;  // sin(tilt) / F = 5 per metre
  const double tan_half = 0.05, k = kImage / (2.0 * tan_half);
  const float yfov = static_cast<float>(2.0 * std::atan(tan_half));
  // Slope -0.03 below the axis (tilt_x) or left of it (tilt_y): the plane lies at
  // z = 1 / (1 / P + 0.03 * 5) there.
  const double z = 1.0 / (1.0 / P + 0.03 * 5.0);
  const double untilted_radius = a * std::abs(P - z) / (P * z) * k;
  for (int axis : {0, 1}) {
    lens::ThinLens lens{F, F / (2.0 * a), P};
    (axis == 0 ? lens.aperture.tilt_x_deg : lens.aperture.tilt_y_deg) = tilt;
    const glm::vec3 lamp(axis == 1 ? static_cast<float>(-0.03 * z) : 0.0f,
                         axis == 0 ? static_cast<float>(-0.03 * z) : 0.0f, -static_cast<float>(z));
    const double side = kLampPixels * z / k;
    const image::Image tilted = lamp_image(lens, yfov, kImage, lamp, side, 1024);
    lens::ThinLens flat{F, F / (2.0 * a), P};
    const image::Image untilted = lamp_image(flat, yfov, kImage, lamp, side, 1024);
    const ChannelMoments sharp = channel_moments(tilted, 1), blurred = channel_moments(untilted, 1);
    // In focus: only the lamp's square and the pixel's box (kExtraPolar) remain.
    EXPECT_LT(sharp.polar, kExtraPolar + 0.3) << "axis " << axis;
    EXPECT_NEAR(std::sqrt(2.0 * (blurred.polar - kExtraPolar)), untilted_radius,
                0.05 * untilted_radius) << "axis " << axis;
    EXPECT_GT(untilted_radius, 4.0);
    // The lamp lands where its pinhole ray does (tilt does not move the image).
    EXPECT_NEAR(axis == 0 ? sharp.cy : sharp.cx, -0.03 * k, 0.3) << "axis " << axis;
  }
}

// An aperture image: transmission over the square around the round aperture, top row up,
// importance-sampled. This one transmits 1 over x in [1/4, 1], y in [-1/2, 1/2] (right of the
// centre) and 1/4 over the mirror rectangle on the left, nothing elsewhere. Behind the focus the
// bokeh is the image scaled by the circle of confusion c, upright: a 3c/4 x c box centred at
// (+5c/8, 0) holding 4/5 of the light and its mirror holding 1/5.
class ApertureImageBokeh : public dofcache::testing::ScratchDirTest {};

TEST_F(ApertureImageBokeh, TheBokehIsTheImageScaledByTheCircleOfConfusion) {
  image::Image t(64, 64, 3, 0.0f);
  for (int y = 16; y < 48; ++y)
    for (int x = 0; x < 24; ++x)
      for (int k = 0; k < 3; ++k) t.at(x, y, k) = 0.25f, t.at(x + 40, y, k) = 1.0f;
  const std::string file = path("aperture.exr");
  image::write_image(file, t);
  lens::ThinLens lens{0.05, 2.0, 1.0};
  lens.aperture.image = file;
  const float yfov = 0.0286f;
  const lens::LensImaging imaging{lens, yfov, kSize};
  const double c = imaging.coc_radius_pixels(kDepth);
  const double side = kLampPixels * imaging.pixel_footprint(kDepth);
  const image::Image im =
      lamp_image(lens, yfov, kSize, {0.0f, 0.0f, -static_cast<float>(kDepth)}, side, 4096);
  double right = 0, left = 0, rx = 0, ry = 0, rxx = 0;
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      const double v = im.at(x, y, 1), px = x + 0.5 - kSize / 2.0, py = kSize / 2.0 - y - 0.5;
      if (px > 0) right += v, rx += v * px, ry += v * py, rxx += v * px * px;
      else left += v;
    }
  EXPECT_NEAR(right / (right + left), 0.8, 0.01);
  rx /= right, ry /= right, rxx = rxx / right - rx * rx;
  EXPECT_NEAR(rx, 5.0 * c / 8.0, 0.03 * c);
  EXPECT_NEAR(ry, 0.0, 0.3);
  // A w-wide box's second moment w^2 / 12, plus the lamp's and the pixel's (side^2 + 1) / 12.
  EXPECT_NEAR(std::sqrt(12.0 * rxx - kLampPixels * kLampPixels - 1.0), 0.75 * c, 0.04 * c);
  // An unreadable or black image is one line naming the file.
  lens::ApertureShape missing;
  missing.image = path("nothing.png");
  EXPECT_THROW(lens::Aperture{missing}, Error);
  image::write_image(path("black.exr"), image::Image(8, 8, 3, 0.0f));
  lens::ApertureShape black;
  black.image = path("black.exr");
  try {
    lens::Aperture{black};
    ADD_FAILURE() << "a black aperture image was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("transmits no light"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace dofcache::render
