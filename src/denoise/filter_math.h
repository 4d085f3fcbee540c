#pragma once
// What the a-trous filters share (atrous.cpp, render_filter.cpp): the B3-spline taps, fast
// weights, and the checks of their guides.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "dofcache/core/error.h"
#include "dofcache/image/image.h"

namespace dofcache::denoise::detail {

// The 5-tap B3 spline; a tap's distance from the centre in steps, |(kx - 2, ky - 2)|: one of six
// values.
constexpr float kKernel[5] = {1.0f / 16.0f, 1.0f / 4.0f, 3.0f / 8.0f, 1.0f / 4.0f, 1.0f / 16.0f};
constexpr float kDistances[6] = {0.0f, 1.0f, 1.4142136f, 2.0f, 2.2360680f, 2.8284271f};
constexpr int kDistanceClass[5][5] = {{5, 4, 3, 4, 5}, {4, 2, 1, 2, 4}, {3, 1, 0, 1, 3},
                                      {4, 2, 1, 2, 4}, {5, 4, 3, 4, 5}};

inline float luminance(const float* c) {
  return 0.2126f * c[0] + 0.7152f * c[1] + 0.0722f * c[2];
}

// Throws unless `g` is given with `channels` channels and the colour's size.
inline void check_guide(const image::Image* g, const image::Image& color, int channels,
                        const char* what) {
  if (!g || g->width() != color.width() || g->height() != color.height() ||
      g->channels() != channels)
    throw Error(std::string("denoise: the ") + what + " guide must be " +
                std::to_string(channels) + " channel(s) of the colour's size");
}

// x^e for an integer e >= 1 by squaring (e = 64: six multiplications).
inline float power(float x, int e) {
  float r = 1.0f;
  while (e > 0) {
    if (e & 1) r *= x;
    x *= x;
    e >>= 1;
  }
  return r;
}

// exp(-e) for e >= 0, to about 1e-5 relative: 2^-(e log2 e) split into an integer power of two
// (built in the float's exponent bits) and a fraction by a degree-5 polynomial. A weight needs
// no more, and it is cheaper than std::exp in the filter's innermost loop.
inline float exp_neg(float e) {
  const float t = -e * 1.44269504f;  // log2(e)
  if (!(t >= -126.0f)) return 0.0f;  // also NaN (a zero depth scale): no weight
  const float fi = std::floor(t);
  const float f = t - fi;  // [0, 1)
  // 2^f on [0, 1): the Taylor series of e^(f ln 2) to the fifth power.
  const float l = 0.69314718f * f;
  const float p =
      1.0f + l * (1.0f + l * (0.5f + l * (1.0f / 6.0f + l * (1.0f / 24.0f + l / 120.0f))));
  const std::int32_t bits = (static_cast<std::int32_t>(fi) + 127) << 23;
  float scale;
  std::memcpy(&scale, &bits, sizeof scale);
  return p * scale;
}

// f(y) for every row y in [0, h), rows in parallel (inside the caller's thread arena).
template <class Row>
void for_rows(int h, const Row& f) {
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& b) {
    for (int y = b.begin(); y < b.end(); ++y) f(y);
  });
}

// The largest depth step from pixel (x, y) to a 4-neighbour on the same object (id) that sees
// something (finite depth): how much depth may change per pixel along a surface, so that a
// tilted floor is not cut at every pixel. `px` is row-major w x h, each with .depth and .id.
template <class Pixel>
float depth_gradient(const std::vector<Pixel>& px, int w, int h, int x, int y) {
  const Pixel& p = px[static_cast<std::size_t>(y) * w + x];
  float grad = 0.0f;
  for (auto [dx, dy] : {std::pair{1, 0}, std::pair{-1, 0}, std::pair{0, 1}, std::pair{0, -1}}) {
    const int qx = x + dx, qy = y + dy;
    if (qx < 0 || qy < 0 || qx >= w || qy >= h) continue;
    const Pixel& q = px[static_cast<std::size_t>(qy) * w + qx];
    if (std::isfinite(q.depth) && q.id == p.id) grad = std::max(grad, std::abs(q.depth - p.depth));
  }
  return grad;
}

// The sample variance of `lum` over the (2r + 1)^2 window around (x, y), over the pixels j for
// which takes(j) holds; 0 with fewer than two.
template <class Takes>
float window_variance(const std::vector<float>& lum, int w, int h, int x, int y, int r,
                      const Takes& takes) {
  double sum = 0, sum2 = 0;
  int count = 0;
  for (int qy = std::max(0, y - r); qy <= std::min(h - 1, y + r); ++qy)
    for (int qx = std::max(0, x - r); qx <= std::min(w - 1, x + r); ++qx) {
      const std::size_t j = static_cast<std::size_t>(qy) * w + qx;
      if (!takes(j)) continue;
      sum += lum[j], sum2 += double(lum[j]) * lum[j], ++count;
    }
  return count > 1 ? static_cast<float>(std::max(0.0, (sum2 - sum * sum / count) / (count - 1)))
                   : 0.0f;
}

// After an iteration: the filtered values become the current ones (each buffer swapped with its
// `next`) and their luminance is taken again.
inline void next_iteration(std::vector<float>& value, std::vector<float>& next_value,
                           std::vector<float>& variance, std::vector<float>& next_variance,
                           std::vector<float>& luma, int w, int h) {
  std::swap(value, next_value);
  std::swap(variance, next_variance);
  for_rows(h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * w + x;
      luma[i] = luminance(&value[i * 3]);
    }
  });
}

}  // namespace dofcache::denoise::detail
