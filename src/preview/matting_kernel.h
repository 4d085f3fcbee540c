#pragma once
// The matting functions of layers.h in the form the per-pixel loops use.
#include <algorithm>

#include "kernels.h"

namespace dofcache::preview::detail {

// Which matte of layer i a pass produces.
enum class MattePart {
  Trapezoid,  // Kraus & Strengert: the trapezoid over c_{i-2} .. c_{i+1} ("over" composite)
  NearHalf,   // slab composite: the hat's rising half, c_{i-1} < c <= c_i (layer 0: c <= c_0)
  FarHalf,    // slab composite: the hat's falling half, c_i < c < c_{i+1} (last layer: c > c_i)
};

struct Matte {
  float c0 = 0, inv_step = 0;  // anchor 0 and 1 / spacing
  int i = 0, n = 1;            // this layer, layer count
  MattePart part = MattePart::Trapezoid;

  // Position of c relative to anchor i, in anchor steps.
  float u(float c) const { return (c - c0) * inv_step - static_cast<float>(i); }

  float weight(float c) const {
    if (n <= 1) return part == MattePart::FarHalf ? 0.0f : 1.0f;
    const float t = u(c);
    switch (part) {
      case MattePart::NearHalf:
        return t > 0.0f ? 0.0f : i == 0 ? 1.0f : std::max(1.0f + t, 0.0f);
      case MattePart::FarHalf:
        return t <= 0.0f ? 0.0f : i == n - 1 ? 1.0f : std::max(1.0f - t, 0.0f);
      case MattePart::Trapezoid:
        break;
    }
    return trapezoid(t);
  }
  // The trapezoid at t = u(c): min(rising ramp, falling ramp), each switched off on the end layer
  // that has no such ramp (the plateau is where both are saturated at 1). 1 for a single layer.
  float trapezoid(float t) const {
    const float rise = std::max(std::clamp(t + 2.0f, 0.0f, 1.0f), i == 0 ? 1.0f : 0.0f);
    const float fall = std::max(std::clamp(1.0f - t, 0.0f, 1.0f), i == n - 1 ? 1.0f : 0.0f);
    return std::min(rise, fall);
  }
  // The premultiplied trapezoid layer of `count` pixels {r, g, b, c}: weight() with its branches
  // hoisted out of the per-pixel loop (the layered preview's hottest path). out may be src.
  void premultiply_trapezoid(const Rgba* src, Rgba* out, int count) const {
    // Four pixels at a time: the weights as one vector, the same operations as trapezoid().
    const Float4 c0v = {c0, c0, c0, c0}, sv = {inv_step, inv_step, inv_step, inv_step};
    const float fi = static_cast<float>(i);
    const Float4 iv = {fi, fi, fi, fi}, zero = {0, 0, 0, 0}, one = {1, 1, 1, 1}, two = {2, 2, 2, 2};
    const float rf = i == 0 ? 1.0f : 0.0f, ff = i == n - 1 ? 1.0f : 0.0f;
    const Float4 rise_floor = {rf, rf, rf, rf}, fall_floor = {ff, ff, ff, ff};
    auto vmax = [](Float4 a, Float4 b) { return a < b ? b : a; };  // std::max
    auto vmin = [](Float4 a, Float4 b) { return b < a ? b : a; };  // std::min
    auto vclamp = [&](Float4 v) { return v < zero ? zero : (one < v ? one : v); };
    int k = 0;
    for (; k + 4 <= count; k += 4) {
      const Float4 c = {src[k].a, src[k + 1].a, src[k + 2].a, src[k + 3].a};
      const Float4 t = (c - c0v) * sv - iv;
      const Float4 w = vmin(vmax(vclamp(t + two), rise_floor), vmax(vclamp(one - t), fall_floor));
      for (int j = 0; j < 4; ++j) {
        Float4 v = as_vec(src[k + j]) * w[j];
        v[3] = w[j];
        out[k + j] = as_rgba(v);
      }
    }
    for (; k < count; ++k) {
      const float w = trapezoid(u(src[k].a));
      out[k] = Rgba{src[k].r * w, src[k].g * w, src[k].b * w, w};
    }
  }
  // Culled pixels filled by pull-push (what the layer extrapolates behind nearer content). On the
  // trapezoid the matte itself. On the hat's halves the fill is the slab's backing: it belongs to
  // the slab [c_i, c_{i+1}] (the holes of layer i+1, c < c_i) and is split between its two parts
  // by the hat at the fill's CoC, like a surface there: the far half of layer i takes weight 1
  // up to c_i, then the falling ramp; the near half of layer i+1 takes the rising ramp. A fill
  // extrapolated from a surface just behind c_i is thus blurred with that surface's radius r_i
  // (with r_{i+1} the two blurred coverages left a gap along the contour where a curved surface
  // crosses c_i, through which what lies behind showed as a seam).
  float fill_weight(float c) const {
    if (part == MattePart::FarHalf) return n > 1 && u(c) <= 0.0f ? 1.0f : weight(c);
    return weight(c);
  }
  // Revealed fragments: on the trapezoid a hard front cut, nothing on the rising ramp. On the
  // hat's halves as fills: a fragment is used only where the pinhole surface lies in a nearer
  // slab, so it never composites over it.
  float revealed_weight(float c) const {
    if (part != MattePart::Trapezoid) return fill_weight(c);
    if (n <= 1) return 1.0f;
    float t = u(c);
    if (t < -1.0f) return i == 0 ? 1.0f : 0.0f;
    if (t <= 0.0f) return 1.0f;
    return i == n - 1 ? 1.0f : std::clamp(1.0f - t, 0.0f, 1.0f);
  }
};

}  // namespace dofcache::preview::detail
