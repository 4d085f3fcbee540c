#pragma once
// What the a-trous filters share (atrous.cpp, render_filter.cpp): the B3-spline taps, fast
// weights, and the checks of their guides.
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>

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

}  // namespace dofcache::denoise::detail
