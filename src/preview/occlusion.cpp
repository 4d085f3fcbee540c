// Occlusion masks of the paper's section 3.2 with the lens-reach restriction (rule in
// occlusion.h).
#include "dofcache/preview/occlusion.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>

#include "dofcache/core/error.h"
#include "kernels.h"

namespace dofcache::preview {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// 1D squared Euclidean distance transform of f (Felzenszwalb & Huttenlocher 2012), n samples.
// f holds 0 (open) or a large value; v, z are scratch of n and n + 1.
void edt_1d(const float* f, float* d, int n, int* v, float* z) {
  auto cut = [&](int q, int p) {  // where the parabolas rooted at q and p intersect
    return ((f[q] + static_cast<float>(q) * q) - (f[p] + static_cast<float>(p) * p)) /
           (2.0f * static_cast<float>(q - p));
  };
  int k = 0;
  v[0] = 0;
  z[0] = -kInf;
  z[1] = kInf;
  for (int q = 1; q < n; ++q) {
    float s = cut(q, v[k]);
    while (s <= z[k]) s = cut(q, v[--k]);
    ++k;
    v[k] = q;
    z[k] = s;
    z[k + 1] = kInf;
  }
  k = 0;
  for (int q = 0; q < n; ++q) {
    while (z[k + 1] < static_cast<float>(q)) ++k;
    float dq = static_cast<float>(q - v[k]);
    d[q] = dq * dq + f[v[k]];
  }
}

// Squared distance from every pixel to the nearest pixel with open[p] != 0 (huge if none).
void distance_to_open(const std::vector<unsigned char>& open, int W, int H,
                      std::vector<float>& dist2) {
  constexpr float kFar = 1e20f;
  std::vector<float> tmp(static_cast<size_t>(W) * H);
  dist2.resize(tmp.size());
  // Columns: for a binary image the 1D transform is the squared distance to the nearest open
  // pixel of the column (kFar if none), found by one sweep down and one up. Swept a row at a
  // time over a band of columns, so memory is read in order.
  detail::parallel_rows(
      W,
      [&](int x0, int x1) {
        constexpr int kNone = std::numeric_limits<int>::max() / 4;
        std::vector<int> last(x1 - x0, -kNone);
        for (int y = 0; y < H; ++y)
          for (int x = x0; x < x1; ++x) {
            const size_t p = static_cast<size_t>(y) * W + x;
            if (open[p]) last[x - x0] = y;
            const int d = y - last[x - x0];
            tmp[p] = d >= kNone ? kFar : static_cast<float>(d) * static_cast<float>(d);
          }
        std::fill(last.begin(), last.end(), kNone + H);
        for (int y = H - 1; y >= 0; --y)
          for (int x = x0; x < x1; ++x) {
            const size_t p = static_cast<size_t>(y) * W + x;
            if (open[p]) last[x - x0] = y;
            const int d = last[x - x0] - y;
            if (d < kNone) tmp[p] = std::min(tmp[p], static_cast<float>(d) * static_cast<float>(d));
          }
      },
      64);
  detail::parallel_rows(H, [&](int y0, int y1) {  // rows
    std::vector<float> d(W), z(W + 1);
    std::vector<int> v(W);
    for (int y = y0; y < y1; ++y) {
      edt_1d(tmp.data() + static_cast<size_t>(y) * W, d.data(), W, v.data(), z.data());
      std::copy(d.begin(), d.end(), dist2.begin() + static_cast<size_t>(y) * W);
    }
  });
}

// Minimum (Less) or maximum (Greater) over the window [i - r, i + r] (clamped) of n values read
// with `stride`, written to out (van Herk / Gil-Werman: three passes whatever r). `pad` lies
// outside the frame: +inf for the minimum, -inf for the maximum.
template <class Better>
void extremum_filter_1d(const float* in, std::ptrdiff_t stride, int n, int r, float* out,
                        std::vector<float>& g, std::vector<float>& h) {
  constexpr float pad = Better{}(0.0f, 1.0f) ? kInf : -kInf;
  auto pick = [](float a, float b) { return Better{}(b, a) ? b : a; };
  const int k = 2 * r + 1, len = n + 2 * r;
  g.resize(len);
  h.resize(len);
  auto at = [&](int i) { return i < r || i >= r + n ? pad : in[(i - r) * stride]; };
  for (int i = 0; i < len; ++i) g[i] = (i % k == 0) ? at(i) : pick(g[i - 1], at(i));
  for (int i = len - 1; i >= 0; --i)
    h[i] = (i % k == k - 1 || i == len - 1) ? at(i) : pick(h[i + 1], at(i));
  for (int i = 0; i < n; ++i) out[i * stride] = pick(h[i], g[i + k - 1]);
}

// The extremum over the (2r + 1)^2 square around every pixel, in place.
template <class Better>
void extremum_filter(std::vector<float>& img, int W, int H, int r) {
  std::vector<float> tmp(img.size());
  detail::parallel_rows(H, [&](int y0, int y1) {
    std::vector<float> g, h;
    for (int y = y0; y < y1; ++y)
      extremum_filter_1d<Better>(img.data() + static_cast<size_t>(y) * W, 1, W, r,
                                 tmp.data() + static_cast<size_t>(y) * W, g, h);
  });
  detail::parallel_rows(W, [&](int x0, int x1) {
    std::vector<float> g, h;
    for (int x = x0; x < x1; ++x)
      extremum_filter_1d<Better>(tmp.data() + x, W, H, r, img.data() + x, g, h);
  });
}

// The signed CoC of every pixel, as the post-process computes it.
std::vector<float> signed_cocs(const image::Image& depth, const CocMap& coc_of) {
  const int W = depth.width(), H = depth.height();
  std::vector<float> coc(static_cast<size_t>(W) * H);
  const float* d = depth.data().data();
  detail::parallel_rows(H, [&](int y0, int y1) {
    for (size_t p = static_cast<size_t>(y0) * W; p < static_cast<size_t>(y1) * W; ++p)
      coc[p] = coc_of(d[p]);
  });
  return coc;
}

// The constants of rule (3) for layer j: open pixels have c >= c_j; a revealed surface has
// c < c_hi; the nearest occluder anywhere has c_front (+inf if the plane clips nothing), so the
// occluder window of half-width `window` covers every reach rho_j.
struct LayerReach {
  float cj = 0, c_hi = 0, c_front = kInf;
  int window = 0;
};

LayerReach layer_reach(const std::vector<float>& coc, const LayerPlan& plan, const CocMap& coc_of,
                       int j) {
  const int n = plan.size();
  LayerReach r;
  r.cj = static_cast<float>(plan.layers[j].signed_coc);
  r.c_hi = j + 1 < n ? static_cast<float>(plan.layers[j + 1].signed_coc)
                     : static_cast<float>(std::clamp(coc_of.k(), -coc_of.limit(), coc_of.limit()));
  for (float c : coc)
    if (c < r.cj) r.c_front = std::min(r.c_front, c);
  r.window = std::max(0, static_cast<int>(std::ceil(0.5 * (r.c_hi - r.c_front))));
  return r;
}

// Rule (3) at every pixel of layer j: region[p] = 1 iff an open pixel lies within
// rho_j(p) + 1/2 of p. The distances and occluder minima are computed on the clipped pixels' box
// grown by the occluder window (+2): an open pixel that near lies inside it, and outside it every
// pixel is open (distance 0) with no clipped pixel in its window.
void reach_region(const std::vector<float>& coc, int W, int H, const LayerReach& lr,
                  std::vector<float>& region) {
  auto passes = [&](float d2, float m) {
    const float reach = 0.5f * (lr.c_hi - m) + 0.5f;
    return reach >= 0 && d2 <= reach * reach;
  };
  int bx0 = W, by0 = H, bx1 = 0, by1 = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      if (coc[static_cast<size_t>(y) * W + x] < lr.cj) {
        bx0 = std::min(bx0, x);
        by0 = std::min(by0, y);
        bx1 = std::max(bx1, x + 1);
        by1 = y + 1;
      }
  for (size_t p = 0; p < coc.size(); ++p) region[p] = passes(0.0f, coc[p]) ? 1.0f : 0.0f;
  if (bx0 >= bx1) return;
  const int grow = lr.window + 2;
  const int rx0 = std::max(bx0 - grow, 0), ry0 = std::max(by0 - grow, 0);
  const int rx1 = std::min(bx1 + grow, W), ry1 = std::min(by1 + grow, H);
  const int rw = rx1 - rx0, rh = ry1 - ry0;
  std::vector<unsigned char> open(static_cast<size_t>(rw) * rh);
  std::vector<float> nearest(open.size(), kInf), dist2;
  for (int y = 0; y < rh; ++y)
    for (int x = 0; x < rw; ++x) {
      size_t q = static_cast<size_t>(y) * rw + x;
      float c = coc[static_cast<size_t>(y + ry0) * W + x + rx0];
      open[q] = c >= lr.cj;
      if (!open[q]) nearest[q] = c;
    }
  extremum_filter<std::less<float>>(nearest, rw, rh, lr.window);
  distance_to_open(open, rw, rh, dist2);
  for (int y = ry0; y < ry1; ++y)
    for (int x = rx0; x < rx1; ++x) {
      size_t p = static_cast<size_t>(y) * W + x;
      size_t q = static_cast<size_t>(y - ry0) * rw + (x - rx0);
      region[p] = passes(dist2[q], std::min(nearest[q], coc[p])) ? 1.0f : 0.0f;
    }
}

}  // namespace

std::vector<image::Image> lens_reach_regions(const image::Image& depth, const LayerPlan& plan,
                                             const lens::LensImaging& imaging,
                                             const PreviewOptions& options, int count) {
  const int n = count < 0 ? plan.size() : std::min(count, plan.size());
  const int W = depth.width(), H = depth.height();
  if (depth.channels() != 1) throw Error("occlusion masks: depth must be 1 channel");
  std::vector<image::Image> regions(plan.size(), image::Image(W, H, 1, 0.0f));
  if (n < 2 || W == 0 || H == 0) return regions;
  if (!options.mask_lens_reach) {
    for (int j = 1; j < n; ++j) regions[j] = image::Image(W, H, 1, 1.0f);
    return regions;
  }
  const CocMap coc_of(imaging, options.max_coc_radius);
  const std::vector<float> coc = signed_cocs(depth, coc_of);
  // Layers are independent: one task each.
  tbb::parallel_for(1, n, [&](int j) {
    reach_region(coc, W, H, layer_reach(coc, plan, coc_of, j), regions[j].data());
  });
  return regions;
}

std::vector<image::Image> build_occlusion_masks(const std::vector<image::Image>& id_layers,
                                                const std::vector<image::Image>& regions) {
  const int n = static_cast<int>(regions.size());
  if (static_cast<int>(id_layers.size()) != n)
    throw Error("build_occlusion_masks: " + std::to_string(id_layers.size()) +
                " id layers for " + std::to_string(n) + " layers");
  if (n == 0) return {};
  const int W = regions[0].width(), H = regions[0].height();
  for (int j = 0; j < n; ++j)
    if (id_layers[j].width() != W || id_layers[j].height() != H || id_layers[j].channels() != 1 ||
        regions[j].width() != W || regions[j].height() != H || regions[j].channels() != 1)
      throw Error("build_occlusion_masks: every id layer must be 1 channel of the depth's size");
  std::vector<image::Image> masks(n, image::Image(W, H, 1, 0.0f));
  const float* id0 = id_layers[0].data().data();
  detail::parallel_rows(H, [&](int y0, int y1) {
    for (int j = 1; j < n; ++j) {
      const float* idj = id_layers[j].data().data();
      const float* idn = j + 1 < n ? id_layers[j + 1].data().data() : nullptr;
      const float* in = regions[j].data().data();
      float* mask = masks[j].data().data();
      for (size_t p = static_cast<size_t>(y0) * W; p < static_cast<size_t>(y1) * W; ++p) {
        const bool revealed = idj[p] >= 0 && idj[p] != id0[p] && (!idn || idn[p] != idj[p]);
        mask[p] = revealed && in[p] > 0.5f ? 1.0f : 0.0f;
      }
    }
  });
  return masks;
}

std::vector<image::Image> build_occlusion_masks(const std::vector<image::Image>& id_layers,
                                                const image::Image& depth, const LayerPlan& plan,
                                                const lens::LensImaging& imaging,
                                                const PreviewOptions& options) {
  if (static_cast<int>(id_layers.size()) != plan.size())
    throw Error("build_occlusion_masks: " + std::to_string(id_layers.size()) +
                " id layers for a plan of " + std::to_string(plan.size()) + " layers");
  if (depth.channels() != 1) throw Error("build_occlusion_masks: depth must be 1 channel");
  for (const image::Image& ids : id_layers)
    if (ids.width() != depth.width() || ids.height() != depth.height() || ids.channels() != 1)
      throw Error("build_occlusion_masks: every id layer must be 1 channel of the depth's size");
  return build_occlusion_masks(id_layers, lens_reach_regions(depth, plan, imaging, options));
}

}  // namespace dofcache::preview
