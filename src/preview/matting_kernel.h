#pragma once
// The matting trapezoid of layers.h in the form the per-pixel loops use.
#include <algorithm>

namespace dofcache::preview::detail {

struct Matte {
  float c0 = 0, inv_step = 0;  // anchor 0 and 1 / spacing
  int i = 0, n = 1;            // this layer, layer count

  // Position of c relative to anchor i, in anchor steps.
  float u(float c) const { return (c - c0) * inv_step - static_cast<float>(i); }

  // The trapezoid without branches: min(rising ramp, falling ramp), each switched off on the end
  // layer that has no such ramp. (The plateau is where both ramps are saturated at 1.)
  float weight(float c) const {
    float t = u(c);
    float rise = std::max(std::clamp(t + 2.0f, 0.0f, 1.0f), i == 0 ? 1.0f : 0.0f);
    float fall = std::max(std::clamp(1.0f - t, 0.0f, 1.0f), i == n - 1 ? 1.0f : 0.0f);
    return n <= 1 ? 1.0f : std::min(rise, fall);
  }
  // Hard front cut for revealed fragments: nothing on the rising ramp.
  float revealed_weight(float c) const {
    if (n <= 1) return 1.0f;
    float t = u(c);
    if (t < -1.0f) return i == 0 ? 1.0f : 0.0f;
    if (t <= 0.0f) return 1.0f;
    return i == n - 1 ? 1.0f : std::clamp(1.0f - t, 0.0f, 1.0f);
  }
};

}  // namespace dofcache::preview::detail
