// Occlusion masks of the paper's section 3.2 with the lens-reach restriction (rule in
// occlusion.h).
#include "dofcache/preview/occlusion.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
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
  detail::parallel_rows(W, [&](int x0, int x1) {  // columns
    std::vector<float> f(H), d(H), z(H + 1);
    std::vector<int> v(H);
    for (int x = x0; x < x1; ++x) {
      for (int y = 0; y < H; ++y) f[y] = open[static_cast<size_t>(y) * W + x] ? 0.0f : kFar;
      edt_1d(f.data(), d.data(), H, v.data(), z.data());
      for (int y = 0; y < H; ++y) tmp[static_cast<size_t>(y) * W + x] = d[y];
    }
  });
  detail::parallel_rows(H, [&](int y0, int y1) {  // rows
    std::vector<float> d(W), z(W + 1);
    std::vector<int> v(W);
    for (int y = y0; y < y1; ++y) {
      edt_1d(tmp.data() + static_cast<size_t>(y) * W, d.data(), W, v.data(), z.data());
      std::copy(d.begin(), d.end(), dist2.begin() + static_cast<size_t>(y) * W);
    }
  });
}

// Minimum over the window [i - r, i + r] (clamped) of n values read with `stride`, written to out
// (van Herk / Gil-Werman: three passes whatever r).
void min_filter_1d(const float* in, std::ptrdiff_t stride, int n, int r, float* out,
                   std::vector<float>& g, std::vector<float>& h) {
  const int k = 2 * r + 1, len = n + 2 * r;
  g.resize(len);
  h.resize(len);
  auto at = [&](int i) { return i < r || i >= r + n ? kInf : in[(i - r) * stride]; };
  for (int i = 0; i < len; ++i) g[i] = (i % k == 0) ? at(i) : std::min(g[i - 1], at(i));
  for (int i = len - 1; i >= 0; --i)
    h[i] = (i % k == k - 1 || i == len - 1) ? at(i) : std::min(h[i + 1], at(i));
  for (int i = 0; i < n; ++i) out[i * stride] = std::min(h[i], g[i + k - 1]);
}

void min_filter(std::vector<float>& img, int W, int H, int r) {
  std::vector<float> tmp(img.size());
  detail::parallel_rows(H, [&](int y0, int y1) {
    std::vector<float> g, h;
    for (int y = y0; y < y1; ++y)
      min_filter_1d(img.data() + static_cast<size_t>(y) * W, 1, W, r,
                    tmp.data() + static_cast<size_t>(y) * W, g, h);
  });
  detail::parallel_rows(W, [&](int x0, int x1) {
    std::vector<float> g, h;
    for (int x = x0; x < x1; ++x) min_filter_1d(tmp.data() + x, W, H, r, img.data() + x, g, h);
  });
}

}  // namespace

std::vector<image::Image> build_occlusion_masks(const std::vector<image::Image>& id_layers,
                                                const image::Image& depth, const LayerPlan& plan,
                                                const lens::LensImaging& imaging,
                                                const PreviewOptions& options) {
  const int n = plan.size(), W = depth.width(), H = depth.height();
  if (static_cast<int>(id_layers.size()) != n)
    throw Error("build_occlusion_masks: " + std::to_string(id_layers.size()) +
                " id layers for a plan of " + std::to_string(n) + " layers");
  if (depth.channels() != 1) throw Error("build_occlusion_masks: depth must be 1 channel");
  for (const image::Image& ids : id_layers)
    if (ids.width() != W || ids.height() != H || ids.channels() != 1)
      throw Error("build_occlusion_masks: every id layer must be 1 channel of the depth's size");

  const size_t N = static_cast<size_t>(W) * H;
  std::vector<image::Image> masks(n, image::Image(W, H, 1, 0.0f));
  if (n < 2 || N == 0) return masks;

  CocMap coc_of(imaging, options.max_coc_radius);
  std::vector<float> coc(N);
  const float* d = depth.data().data();
  detail::parallel_rows(H, [&](int y0, int y1) {
    for (size_t p = static_cast<size_t>(y0) * W; p < static_cast<size_t>(y1) * W; ++p)
      coc[p] = coc_of(d[p]);
  });
  const float background =
      static_cast<float>(std::clamp(coc_of.k(), -coc_of.limit(), coc_of.limit()));
  const float* id0 = id_layers[0].data().data();

  // Layers are independent: one task each. The lens-reach test runs on the bounding box of the
  // candidates grown by the largest reach (nothing farther can matter).
  tbb::parallel_for(1, n, [&](int j) {
    const float* idj = id_layers[j].data().data();
    const float* idn = j + 1 < n ? id_layers[j + 1].data().data() : nullptr;
    float* mask = masks[j].data().data();
    int bx0 = W, by0 = H, bx1 = 0, by1 = 0;
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        size_t p = static_cast<size_t>(y) * W + x;
        bool revealed = idj[p] >= 0 && idj[p] != id0[p] && (!idn || idn[p] != idj[p]);
        mask[p] = revealed ? 1.0f : 0.0f;
        if (revealed) {
          bx0 = std::min(bx0, x);
          by0 = std::min(by0, y);
          bx1 = std::max(bx1, x + 1);
          by1 = y + 1;
        }
      }
    if (bx0 >= bx1 || !options.mask_lens_reach) return;

    // Lens reach: an open pixel within rho_j(p) = (c_hi - m_j(p)) / 2 (+ 1/2 px).
    const float cj = static_cast<float>(plan.layers[j].signed_coc);
    const float c_hi = j + 1 < n ? static_cast<float>(plan.layers[j + 1].signed_coc) : background;
    float c_front = kInf;
    for (size_t p = 0; p < N; ++p)
      if (coc[p] < cj) c_front = std::min(c_front, coc[p]);
    const int window = std::max(0, static_cast<int>(std::ceil(0.5 * (c_hi - c_front))));
    const int grow = window + 2;
    const int rx0 = std::max(bx0 - grow, 0), ry0 = std::max(by0 - grow, 0);
    const int rx1 = std::min(bx1 + grow, W), ry1 = std::min(by1 + grow, H);
    const int rw = rx1 - rx0, rh = ry1 - ry0;
    std::vector<unsigned char> open(static_cast<size_t>(rw) * rh);
    std::vector<float> nearest(open.size(), kInf), dist2;
    for (int y = 0; y < rh; ++y)
      for (int x = 0; x < rw; ++x) {
        size_t q = static_cast<size_t>(y) * rw + x;
        float c = coc[static_cast<size_t>(y + ry0) * W + x + rx0];
        open[q] = c >= cj;
        if (!open[q]) nearest[q] = c;
      }
    min_filter(nearest, rw, rh, window);
    distance_to_open(open, rw, rh, dist2);
    for (int y = by0; y < by1; ++y)
      for (int x = bx0; x < bx1; ++x) {
        size_t p = static_cast<size_t>(y) * W + x;
        if (mask[p] == 0) continue;
        size_t q = static_cast<size_t>(y - ry0) * rw + (x - rx0);
        float m = std::min(nearest[q], coc[p]);
        float reach = 0.5f * (c_hi - m) + 0.5f;
        if (!(reach >= 0) || dist2[q] > reach * reach) mask[p] = 0;
      }
  });
  return masks;
}

}  // namespace dofcache::preview
