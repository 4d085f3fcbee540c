// Error metrics against a reference: relMSE (as in pbrt), MSE, PSNR and SSIM (Wang et al. 2004).
// Sums are formed per row in parallel and added in row order, so results do not depend on the
// number of threads.
#include "dofcache/image/metrics.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "dofcache/core/error.h"

namespace dofcache::image {
namespace {

// relMSE denominator offset: keeps dark reference pixels from dominating (pbrt's choice).
constexpr double kRelEpsilon = 1e-2;

// SSIM constants (Wang et al. 2004, eq. (13) and Sec. III-C): K1 = 0.01, K2 = 0.03, L = 1.
constexpr double kC1 = 0.01 * 0.01;
constexpr double kC2 = 0.03 * 0.03;
constexpr int kSsimRadius = 5;  // 11x11 window
constexpr double kSsimSigma = 1.5;

std::string shape(const Image& im) {
  return std::to_string(im.width()) + "x" + std::to_string(im.height()) + "x" +
         std::to_string(im.channels());
}

void check_same_shape(const Image& test, const Image& reference, const char* what) {
  if (!test.same_shape(reference))
    throw Error(std::string("cannot ") + what + ": test image is " + shape(test) +
                ", reference is " + shape(reference) + " (width x height x channels)");
}

template <class RowFn>
void parallel_rows(int height, RowFn&& fn) {
  tbb::parallel_for(tbb::blocked_range<int>(0, height), [&](const tbb::blocked_range<int>& r) {
    for (int y = r.begin(); y != r.end(); ++y) fn(y);
  });
}

double clamp01(double v) { return std::min(1.0, std::max(0.0, v)); }

// Display luminance (Rec.709 weights) of clamped RGB; a 1-channel image is its own luminance.
std::vector<float> luminance(const Image& im) {
  std::vector<float> out(im.pixel_count());
  const int nc = im.channels();
  parallel_rows(im.height(), [&](int y) {
    for (int x = 0; x < im.width(); ++x) {
      const float* p = im.pixel(x, y);
      double l;
      if (nc >= 3)
        l = 0.2126 * clamp01(p[0]) + 0.7152 * clamp01(p[1]) + 0.0722 * clamp01(p[2]);
      else if (nc == 1)
        l = clamp01(p[0]);
      else
        l = 0.5 * (clamp01(p[0]) + clamp01(p[1]));
      out[static_cast<size_t>(y) * im.width() + x] = static_cast<float>(l);
    }
  });
  return out;
}

// Per-pixel SSIM of the luminance, eq. (13) of Wang et al. 2004, evaluated with a separable
// Gaussian window. Near the border the window is cut to the image and renormalised (for a
// separable window the 2-D normalisation is the product of the 1-D ones). The image is processed
// in strips of rows, each filtering its rows (plus the window's overlap) horizontally into a
// local buffer: the moments stay in double, since variance = E[x^2] - E[x]^2 cancels badly in
// float, while memory stays bounded for large images.
std::vector<float> ssim_map(const std::vector<float>& a, const std::vector<float>& b, int width,
                            int height) {
  std::array<double, 2 * kSsimRadius + 1> w{};
  for (int k = -kSsimRadius; k <= kSsimRadius; ++k)
    w[k + kSsimRadius] = std::exp(-0.5 * k * k / (kSsimSigma * kSsimSigma));

  // Horizontally filtered local statistics of one pixel.
  struct Moments {
    double mx, my, xx, yy, xy;
  };
  constexpr int kStrip = 64;
  const int strips = (height + kStrip - 1) / kStrip;
  std::vector<float> out(static_cast<size_t>(width) * height);
  tbb::parallel_for(0, strips, [&](int strip) {
    const int y0 = strip * kStrip, y1 = std::min(height, y0 + kStrip);
    const int h0 = std::max(0, y0 - kSsimRadius), h1 = std::min(height, y1 + kSsimRadius);
    std::vector<Moments> h(static_cast<size_t>(h1 - h0) * width);
    for (int y = h0; y < h1; ++y)
      for (int x = 0; x < width; ++x) {
        double sw = 0;
        Moments m{0, 0, 0, 0, 0};
        for (int k = std::max(-kSsimRadius, -x); k <= std::min(kSsimRadius, width - 1 - x); ++k) {
          size_t i = static_cast<size_t>(y) * width + x + k;
          double wk = w[k + kSsimRadius], va = a[i], vb = b[i];
          sw += wk, m.mx += wk * va, m.my += wk * vb;
          m.xx += wk * va * va, m.yy += wk * vb * vb, m.xy += wk * va * vb;
        }
        h[static_cast<size_t>(y - h0) * width + x] = {m.mx / sw, m.my / sw, m.xx / sw, m.yy / sw,
                                                      m.xy / sw};
      }
    for (int y = y0; y < y1; ++y)
      for (int x = 0; x < width; ++x) {
        double sw = 0;
        Moments m{0, 0, 0, 0, 0};
        for (int k = std::max(-kSsimRadius, -y); k <= std::min(kSsimRadius, height - 1 - y); ++k) {
          const Moments& s = h[static_cast<size_t>(y + k - h0) * width + x];
          double wk = w[k + kSsimRadius];
          sw += wk, m.mx += wk * s.mx, m.my += wk * s.my;
          m.xx += wk * s.xx, m.yy += wk * s.yy, m.xy += wk * s.xy;
        }
        double mx = m.mx / sw, my = m.my / sw;
        double var_x = m.xx / sw - mx * mx, var_y = m.yy / sw - my * my;
        double cov = m.xy / sw - mx * my;
        double s = ((2 * mx * my + kC1) * (2 * cov + kC2)) /
                   ((mx * mx + my * my + kC1) * (var_x + var_y + kC2));
        out[static_cast<size_t>(y) * width + x] = static_cast<float>(s);
      }
  });
  return out;
}

}  // namespace

ErrorMetrics compare(const Image& test, const Image& reference, const Image* mask) {
  check_same_shape(test, reference, "compare images");
  if (mask &&
      (mask->width() != test.width() || mask->height() != test.height() || mask->channels() != 1))
    throw Error("cannot compare images: mask is " + shape(*mask) + ", expected " +
                std::to_string(test.width()) + "x" + std::to_string(test.height()) + "x1");
  const int width = test.width(), height = test.height(), nc = test.channels();
  auto selected = [&](int x, int y) { return !mask || mask->at(x, y, 0) > 0.5f; };

  struct RowSums {
    double rel = 0, sq = 0, sq_clamped = 0;
    size_t pixels = 0;
  };
  std::vector<RowSums> rows(height);
  parallel_rows(height, [&](int y) {
    RowSums s;
    for (int x = 0; x < width; ++x) {
      if (!selected(x, y)) continue;
      const float* a = test.pixel(x, y);
      const float* b = reference.pixel(x, y);
      for (int c = 0; c < nc; ++c) {
        double d = double(a[c]) - b[c];
        double dc = clamp01(a[c]) - clamp01(b[c]);
        s.rel += d * d / (double(b[c]) * b[c] + kRelEpsilon);
        s.sq += d * d;
        s.sq_clamped += dc * dc;
      }
      ++s.pixels;
    }
    rows[y] = s;
  });
  RowSums total;
  for (const RowSums& r : rows) {
    total.rel += r.rel, total.sq += r.sq, total.sq_clamped += r.sq_clamped;
    total.pixels += r.pixels;
  }
  if (total.pixels == 0 || nc == 0)
    throw Error("cannot compare images: " +
                std::string(mask ? "the mask selects no pixels" : "the images are empty"));

  ErrorMetrics m;
  const double samples = double(total.pixels) * nc;
  m.rel_mse = total.rel / samples;
  m.mse = total.sq / samples;
  const double mse_clamped = total.sq_clamped / samples;
  m.psnr = mse_clamped > 0 ? std::min(kPsnrCapDb, -10.0 * std::log10(mse_clamped)) : kPsnrCapDb;

  std::vector<float> ssim = ssim_map(luminance(test), luminance(reference), width, height);
  std::vector<double> row_ssim(height, 0.0);
  parallel_rows(height, [&](int y) {
    double s = 0;
    for (int x = 0; x < width; ++x)
      if (selected(x, y)) s += ssim[static_cast<size_t>(y) * width + x];
    row_ssim[y] = s;
  });
  double ssim_sum = 0;
  for (double s : row_ssim) ssim_sum += s;
  m.ssim = ssim_sum / double(total.pixels);
  return m;
}

Image relative_error_map(const Image& test, const Image& reference) {
  check_same_shape(test, reference, "compute an error map");
  Image out(test.width(), test.height(), 1);
  const int nc = test.channels();
  parallel_rows(test.height(), [&](int y) {
    for (int x = 0; x < test.width(); ++x) {
      const float* a = test.pixel(x, y);
      const float* b = reference.pixel(x, y);
      double sum = 0;
      for (int c = 0; c < nc; ++c) {
        double d = double(a[c]) - b[c];
        sum += d * d / (double(b[c]) * b[c] + kRelEpsilon);
      }
      out.at(x, y, 0) = static_cast<float>(nc > 0 ? sum / nc : 0.0);
    }
  });
  return out;
}

Image false_color(const Image& values, double max_value) {
  if (values.channels() != 1)
    throw Error("false colour needs a 1-channel image, not " + std::to_string(values.channels()) +
                " channels");
  if (!(max_value > 0) || !std::isfinite(max_value))
    throw Error("false colour needs a positive finite maximum, not " + std::to_string(max_value));

  // Control points in display (sRGB) values, roughly matplotlib's "inferno" run out to white:
  // brightness rises monotonically, so the ramp also reads correctly in grey.
  struct Stop {
    double t, r, g, b;
  };
  static constexpr Stop kRamp[] = {{0.00, 0.00, 0.00, 0.00},
                                   {0.30, 0.38, 0.07, 0.44},
                                   {0.60, 0.93, 0.41, 0.14},
                                   {0.85, 0.98, 0.86, 0.25},
                                   {1.00, 1.00, 1.00, 1.00}};
  // Display -> linear, so that an sRGB writer reproduces the stops exactly.
  auto decode = [](double v) {
    return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
  };

  Image out(values.width(), values.height(), 3);
  parallel_rows(values.height(), [&](int y) {
    for (int x = 0; x < values.width(); ++x) {
      double v = values.at(x, y, 0) / max_value;
      double t = std::isnan(v) ? 1.0 : clamp01(v);
      size_t i = 1;
      while (i + 1 < std::size(kRamp) && t > kRamp[i].t) ++i;
      const Stop& lo = kRamp[i - 1];
      const Stop& hi = kRamp[i];
      double f = (t - lo.t) / (hi.t - lo.t);
      float* p = out.pixel(x, y);
      p[0] = static_cast<float>(decode(lo.r + f * (hi.r - lo.r)));
      p[1] = static_cast<float>(decode(lo.g + f * (hi.g - lo.g)));
      p[2] = static_cast<float>(decode(lo.b + f * (hi.b - lo.b)));
    }
  });
  return out;
}

}  // namespace dofcache::image
