// Image metrics against values computed by hand, and SSIM against a direct (non-separable)
// evaluation of its definition.
#include "dofcache/image/metrics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

#include "dofcache/core/error.h"

namespace dofcache::image {
namespace {

Image random_image(int w, int h, int c, unsigned seed, float lo = 0.0f, float hi = 1.0f) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(lo, hi);
  Image im(w, h, c);
  for (float& v : im.data()) v = u(rng);
  return im;
}

// Constant images: reference 0.5, test 0.6 in every channel.
// d^2 = 0.01; relMSE = 0.01 / (0.25 + 0.01) = 0.0384615385; MSE = 0.01; PSNR = 10 log10(100) = 20.
// SSIM with zero variance: (2*0.6*0.5 + C1) / (0.6^2 + 0.5^2 + C1) = 0.6001 / 0.6101.
constexpr double kOffsetRelMse = 0.01 / 0.26;
constexpr double kOffsetSsim = 0.6001 / 0.6101;

TEST(Metrics, IdenticalImages) {
  Image a = random_image(37, 23, 3, 1);
  ErrorMetrics m = compare(a, a);
  EXPECT_EQ(m.rel_mse, 0.0);
  EXPECT_EQ(m.mse, 0.0);
  EXPECT_EQ(m.psnr, kPsnrCapDb);
  EXPECT_NEAR(m.ssim, 1.0, 1e-12);
}

TEST(Metrics, ConstantOffset) {
  Image ref(16, 12, 3, 0.5f), test(16, 12, 3, 0.6f);
  ErrorMetrics m = compare(test, ref);
  EXPECT_NEAR(m.rel_mse, kOffsetRelMse, 1e-6);
  EXPECT_NEAR(m.mse, 0.01, 1e-7);
  EXPECT_NEAR(m.psnr, 20.0, 1e-4);
  EXPECT_NEAR(m.ssim, kOffsetSsim, 1e-6);
}

TEST(Metrics, PsnrUsesClampedValuesMseDoesNot) {
  // Test 1.5 against 0.5: raw d^2 = 1, relMSE = 1/0.26; displayed 1.0 vs 0.5 gives d^2 = 0.25,
  // PSNR = 10 log10(4) = 6.0206 dB.
  Image ref(8, 8, 3, 0.5f), test(8, 8, 3, 1.5f);
  ErrorMetrics m = compare(test, ref);
  EXPECT_NEAR(m.mse, 1.0, 1e-9);
  EXPECT_NEAR(m.rel_mse, 1.0 / 0.26, 1e-6);
  EXPECT_NEAR(m.psnr, 10.0 * std::log10(4.0), 1e-6);
}

TEST(Metrics, MaskRestrictsPixels) {
  // Left half identical, right half offset by 0.1.
  const int w = 32, h = 16;
  Image ref(w, h, 3, 0.5f), test(w, h, 3, 0.5f);
  for (int y = 0; y < h; ++y)
    for (int x = w / 2; x < w; ++x)
      for (int c = 0; c < 3; ++c) test.at(x, y, c) = 0.6f;

  // Unmasked: half the samples carry the offset error.
  ErrorMetrics all = compare(test, ref);
  EXPECT_NEAR(all.rel_mse, 0.5 * kOffsetRelMse, 1e-6);
  EXPECT_NEAR(all.mse, 0.005, 1e-7);
  EXPECT_NEAR(all.psnr, 10.0 * std::log10(200.0), 1e-4);

  // Mask on the columns x >= 22: every 11x11 window centred there lies in the offset region
  // (cut off only at the image border), so even SSIM is the constant-offset value.
  Image mask(w, h, 1, 0.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 22; x < w; ++x) mask.at(x, y, 0) = 1.0f;
  ErrorMetrics right = compare(test, ref, &mask);
  EXPECT_NEAR(right.rel_mse, kOffsetRelMse, 1e-6);
  EXPECT_NEAR(right.mse, 0.01, 1e-7);
  EXPECT_NEAR(right.psnr, 20.0, 1e-4);
  EXPECT_NEAR(right.ssim, kOffsetSsim, 1e-6);

  // Mask on the identical half: no error at all (the threshold is 0.5, so 0.4 is outside).
  Image left(w, h, 1, 0.4f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w / 2; ++x) left.at(x, y, 0) = 0.9f;
  ErrorMetrics l = compare(test, ref, &left);
  EXPECT_EQ(l.rel_mse, 0.0);
  EXPECT_EQ(l.psnr, kPsnrCapDb);
}

// SSIM straight from its definition: for each pixel, the Gaussian window cut to the image and
// renormalised, local means/variances/covariance, then Wang et al. eq. (13).
double direct_ssim(const Image& a, const Image& b) {
  auto lum = [](const Image& im, int x, int y) {
    auto c = [](float v) { return std::min(1.0, std::max(0.0, double(v))); };
    return 0.2126 * c(im.at(x, y, 0)) + 0.7152 * c(im.at(x, y, 1)) + 0.0722 * c(im.at(x, y, 2));
  };
  const double c1 = 1e-4, c2 = 9e-4;
  double total = 0;
  for (int y = 0; y < a.height(); ++y)
    for (int x = 0; x < a.width(); ++x) {
      double sw = 0, mx = 0, my = 0, xx = 0, yy = 0, xy = 0;
      for (int j = -5; j <= 5; ++j)
        for (int i = -5; i <= 5; ++i) {
          int u = x + i, v = y + j;
          if (u < 0 || v < 0 || u >= a.width() || v >= a.height()) continue;
          double w = std::exp(-(i * i + j * j) / (2 * 1.5 * 1.5));
          double p = lum(a, u, v), q = lum(b, u, v);
          sw += w, mx += w * p, my += w * q, xx += w * p * p, yy += w * q * q, xy += w * p * q;
        }
      mx /= sw, my /= sw, xx /= sw, yy /= sw, xy /= sw;
      double vx = xx - mx * mx, vy = yy - my * my, cov = xy - mx * my;
      total += (2 * mx * my + c1) * (2 * cov + c2) / ((mx * mx + my * my + c1) * (vx + vy + c2));
    }
  return total / (a.width() * a.height());
}

TEST(Metrics, SsimMatchesDirectEvaluation) {
  Image ref = random_image(19, 13, 3, 7, -0.1f, 1.1f);  // includes values that get clamped
  Image test = ref;
  std::mt19937 rng(3);
  std::normal_distribution<float> noise(0.0f, 0.2f);
  for (float& v : test.data()) v += noise(rng);
  double expected = direct_ssim(test, ref);
  EXPECT_LT(expected, 0.95);
  EXPECT_NEAR(compare(test, ref).ssim, expected, 1e-5);
}

TEST(Metrics, SsimFallsWithNoise) {
  Image ref = random_image(64, 48, 3, 11);
  double previous = 1.0;
  for (float sigma : {0.02f, 0.1f, 0.3f}) {
    Image test = ref;
    std::mt19937 rng(5);
    std::normal_distribution<float> noise(0.0f, sigma);
    for (float& v : test.data()) v += noise(rng);
    double s = compare(test, ref).ssim;
    EXPECT_LT(s, previous);
    previous = s;
  }
}

TEST(Metrics, LargeImageIsConsistent) {
  // Full HD exercises the parallel paths; the result must not depend on scheduling.
  Image ref = random_image(1920, 1080, 3, 21);
  Image test(1920, 1080, 3);
  for (size_t i = 0; i < ref.data().size(); ++i) test.data()[i] = ref.data()[i] + 0.1f;
  ErrorMetrics a = compare(test, ref), b = compare(test, ref);
  EXPECT_EQ(a.rel_mse, b.rel_mse);
  EXPECT_EQ(a.ssim, b.ssim);
  EXPECT_NEAR(a.mse, 0.01, 1e-6);
}

TEST(Metrics, ShapeMismatchNamesBothSizes) {
  Image a(4, 4, 3), b(5, 4, 3);
  try {
    compare(a, b);
    FAIL() << "expected dofcache::Error";
  } catch (const Error& e) {
    std::string msg = e.what();
    EXPECT_NE(msg.find("4x4x3"), std::string::npos) << msg;
    EXPECT_NE(msg.find("5x4x3"), std::string::npos) << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos);
  }
  EXPECT_THROW(relative_error_map(a, b), Error);
}

TEST(Metrics, BadMaskIsAnError) {
  Image a(4, 4, 3, 0.5f);
  Image wrong_size(3, 4, 1, 1.0f), wrong_channels(4, 4, 3, 1.0f), empty(4, 4, 1, 0.0f);
  EXPECT_THROW(compare(a, a, &wrong_size), Error);
  EXPECT_THROW(compare(a, a, &wrong_channels), Error);
  EXPECT_THROW(compare(a, a, &empty), Error);
}

TEST(Metrics, RelativeErrorMap) {
  // Reference (0.5,0.5,0.5), test (0.6,0.5,0.4): (0.01/0.26 + 0 + 0.01/0.26) / 3.
  Image ref(3, 2, 3, 0.5f), test(3, 2, 3, 0.5f);
  test.at(1, 1, 0) = 0.6f;
  test.at(1, 1, 2) = 0.4f;
  Image map = relative_error_map(test, ref);
  ASSERT_EQ(map.channels(), 1);
  ASSERT_EQ(map.width(), 3);
  EXPECT_NEAR(map.at(1, 1, 0), 2.0 / 3.0 * kOffsetRelMse, 1e-6);
  EXPECT_EQ(map.at(0, 0, 0), 0.0f);
}

TEST(Metrics, FalseColorRamp) {
  Image v(5, 1, 1);
  v.at(0, 0, 0) = 0.0f;
  v.at(1, 0, 0) = 1.0f;
  v.at(2, 0, 0) = 2.0f;
  v.at(3, 0, 0) = 4.0f;   // the maximum
  v.at(4, 0, 0) = 40.0f;  // beyond it
  Image rgb = false_color(v, 4.0);
  ASSERT_EQ(rgb.channels(), 3);
  for (int c = 0; c < 3; ++c) {
    EXPECT_EQ(rgb.at(0, 0, c), 0.0f);
    EXPECT_NEAR(rgb.at(3, 0, c), 1.0f, 1e-6);
    EXPECT_NEAR(rgb.at(4, 0, c), 1.0f, 1e-6);
  }
  // Brightness rises along the ramp; the middle is coloured, not grey.
  auto lum = [&](int x) {
    return 0.2126 * rgb.at(x, 0, 0) + 0.7152 * rgb.at(x, 0, 1) + 0.0722 * rgb.at(x, 0, 2);
  };
  EXPECT_LT(lum(0), lum(1));
  EXPECT_LT(lum(1), lum(2));
  EXPECT_LT(lum(2), lum(3));
  EXPECT_GT(rgb.at(2, 0, 0), rgb.at(2, 0, 2));  // orange: more red than blue

  EXPECT_THROW(false_color(Image(2, 2, 3), 1.0), Error);
  EXPECT_THROW(false_color(v, 0.0), Error);
}

}  // namespace
}  // namespace dofcache::image
