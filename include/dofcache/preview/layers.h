#pragma once
// Layer planning and matting of the layered depth-of-field preview (paper section 3.1, after
// Kraus & Strengert 2007), with the layers spaced uniformly in circle of confusion over the depth
// range actually present (Schedl & Wimmer 2012).
//
// Everything here works in *signed CoC* c (the CoC diameter of eq. (2.4) in pixels, negative in
// front of the focal plane). c is an increasing function of depth, affine in 1/depth:
//     c(D) = k (1 - P / D),   k = A V_P / (P * pixel_pitch)     (A = F/n, V_P eq. (2.2))
// so it is finite for the background (c(inf) = k) and interpolates sensibly, which raw depth does
// not. The blur radius of a layer is |c| / 2 (eq. (2.6): R = C / 2).
//
// Layer rule (plan_layers). Let [c_min, c_max] be the signed CoC range present in the depth buffer
// (clamped to +-2 max_coc_radius).
//   * a = the smallest blur radius present: 0 if the range contains the focal plane, otherwise
//     min(|c_min|, |c_max|) / 2.
//   * the wanted step in CoC radius: s = max(min_layer_step, (sqrt(2) - 1) a). The pyramid
//     resolves blur radii in powers of two, so what a layer step must resolve is relative to the
//     radius: half an octave (a factor sqrt(2)) at the sharpest depth present, and never below
//     min_layer_step (half the 3 px radius of pyramid level 1).
//   * the anchor spacing in signed CoC (diameter) is step = max(2 s, (c_max - c_min) /
//     (max_layers - 2)), so the count below never exceeds max_layers.
//   * anchors c_i = (k_lo + i) step for k_lo = floor(c_min / step) .. k_hi = ceil(c_max / step):
//     evenly spaced, covering the range present (the end anchors lie at most one step beyond it)
//     and on a grid through c = 0, so the focal plane is an anchor and in-focus pixels are
//     composited unblurred. n = k_hi - k_lo + 1.
//   * a flat range (c_min = c_max) gets one layer at c_min; layer_count > 0 forces that many
//     layers with the end anchors exactly at c_min and c_max.
//   * z_i = depth_for_signed_coc(c_i) (+inf for c_i >= k); r_i = |c_i| / 2.
//
// Matting (matting_weight): the trapezoid over anchors c_{i-2}, c_{i-1}, c_i, c_{i+1} (anchors
// outside 0..n-1 continue the even spacing): 0 before c_{i-2}, rising linearly to 1 at c_{i-1},
// 1 until c_i, falling linearly to 0 at c_{i+1}. The end layers keep their plateau to infinity:
// layer 0 is 1 for every c <= c_0, layer n-1 is 1 for every c >= c_{n-2}.
// The trapezoids overlap (the rising ramp of layer i lies under the plateau of layer i-1: it holds
// the content that the blur of the nearer layer uncovers), so they do not add up to one; what adds
// up to one is the back-to-front "over" composite of the unblurred mattes,
//     sum_i w_i(c) prod_{j<i} (1 - w_j(c)) = 1  for every c,
// whose effective per-layer weights are the hat functions centred on the anchors (linear in c
// between neighbouring anchors). Linearity in c (not in depth) is what makes the effective blur
// radius interpolate linearly between r_{i-1} and r_i.
#include <algorithm>
#include <cmath>
#include <vector>

#include "dofcache/image/image.h"
#include "dofcache/lens/thin_lens.h"
#include "dofcache/preview/options.h"

namespace dofcache::preview {

// Depth -> clamped signed CoC (pixels, diameter), the closed form above.
class CocMap {
 public:
  CocMap(const lens::LensImaging& imaging, double max_coc_radius);
  // +inf, NaN and depths beyond the far limit give the background value c(inf) = k (clamped);
  // depths at or in front of the lens give the near clamp.
  float operator()(double depth) const {  // inline: called per pixel and per revealed fragment
    double c;
    if (std::isnan(depth) || std::isinf(depth)) {
      c = k_;  // background / miss: the limit D -> inf
    } else if (depth <= 0) {
      c = -limit_;
    } else {
      c = k_ * (1.0 - focus_ / depth);
    }
    return static_cast<float>(std::clamp(c, -limit_, limit_));
  }
  double k() const { return k_; }
  double limit() const { return limit_; }  // |c| <= limit = 2 max_coc_radius

 private:
  double k_ = 0, focus_ = 1, limit_ = 0;
};

struct PreviewLayer {
  double signed_coc = 0;   // c_i, pixels (CoC diameter, negative in front of the focal plane)
  double depth = 0;        // z_i = depth_for_signed_coc(c_i): the near plane of L_i and A_i
  double blur_radius = 0;  // r_i = |c_i| / 2, pixels
};

struct LayerPlan {
  std::vector<PreviewLayer> layers;  // front to back (signed CoC increasing)
  double coc_min = 0, coc_max = 0;   // signed CoC range present (clamped)
  double origin = 0;                 // c_0
  double step = 0;                   // anchor spacing in signed CoC (diameter px); 0 for one layer

  int size() const { return static_cast<int>(layers.size()); }
  // c_i = origin + i step; outside 0..n-1 the even spacing continues (used by the end ramps).
  double anchor(int i) const { return origin + i * step; }
};

// The rule above over the CoC range of `depth` (1 channel, metres, +inf for background).
LayerPlan plan_layers(const image::Image& depth, const lens::LensImaging& imaging,
                      const PreviewOptions& options);
// The same rule for a given signed CoC range (clamped like the depth buffer would be).
LayerPlan plan_layers_for_range(double coc_min, double coc_max, const lens::LensImaging& imaging,
                                const PreviewOptions& options);

// w_i(c), the trapezoid above.
float matting_weight(const LayerPlan& plan, int i, double c);
// The matte of a fragment taken from a revealed layer A_j (occlusion fix): w_i with a hard cut on
// the front side, i.e. 0 on the rising ramp (c < c_{i-1}), so that a revealed surface is never
// blended into a layer that still carries (on its plateau) the foreground in front of it.
float revealed_matting_weight(const LayerPlan& plan, int i, double c);
// The hat of layer i, the slab composite's matte (LayerComposite::Slabs): 1 at c_i, falling
// linearly to 0 at c_{i-1} and c_{i+1}; layer 0 is 1 for every c <= c_0, layer n-1 for every
// c >= c_{n-1}. The composite uses its two halves, c <= c_i and c > c_i, separately. The hats add
// up to one for every c.
float hat_weight(const LayerPlan& plan, int i, double c);
// The occluding-edge rule of the edge band (docs/preview.md): 4-neighbours of signed CoC a and b
// (clamped, CocMap) form an occluding edge if they differ by more than 1 px, and the blur of either
// side reaches R = max(1, max(|a|, |b|) / 2) px around it. Returns R, or 0 for no edge. The
// preview benchmark measures error in this band; the occlusion fix's edge trace traces the part of
// it where lens rays can pass the edge (edge_trace.cpp), with the same jump.
inline constexpr float kOccludingEdgeJump = 1.0f;  // px of signed CoC
inline float occluding_edge_radius(float a, float b) {
  const float r = std::max(1.0f, 0.5f * std::max(std::abs(a), std::abs(b)));
  return std::abs(a - b) > kOccludingEdgeJump ? r : 0.0f;
}

// sum_i w_i(c) prod_{j<i} (1 - w_j(c)): the coverage of the unblurred composite (1 for every c).
double composite_coverage(const LayerPlan& plan, double c);

}  // namespace dofcache::preview
