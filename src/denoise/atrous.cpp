#include "dofcache/denoise/atrous.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "dofcache/core/error.h"
#include "dofcache/core/threads.h"
#include "filter_math.h"

namespace dofcache::denoise {
namespace {

using namespace detail;

struct Pixel {
  bool hit = false;
  float depth = 0, gradient = 0, id = -1;
  float n[3] = {0, 0, 0};
};

}  // namespace

image::Image atrous_filter(const image::Image& color, const Guides& g,
                           const AtrousOptions& o) {
  if (color.empty() || color.channels() != 3)
    throw Error("denoise: the colour must be a non-empty RGB image");
  check_guide(g.albedo, color, 3, "albedo");
  check_guide(g.normal, color, 3, "normal");
  check_guide(g.depth, color, 1, "depth");
  check_guide(g.ids, color, 1, "id");
  if (o.iterations < 0 || o.iterations > 10 || !(o.albedo_floor > 0.0f) ||
      o.variance_radius < 0 || o.variance_radius > 16)
    throw Error("denoise: absurd filter options");
  const int w = color.width(), h = color.height();
  const int normal_power = std::max(1, static_cast<int>(std::lround(o.sigma_normal)));

  const std::size_t n = static_cast<std::size_t>(w) * h;
  std::vector<Pixel> px(n);
  std::vector<float> cur(n * 3), next(n * 3), var(n), next_var(n), lum(n);
  const float floor = o.albedo_floor;
  const int r = o.variance_radius;
  auto rows = [h](const auto& f) { for_rows(h, f); };
  run_with_threads(o.threads, [&] {
    // The guides per pixel, and the demodulated irradiance (RGB) with its luminance.
    rows([&](int y) {
      for (int x = 0; x < w; ++x) {
        const std::size_t i = static_cast<std::size_t>(y) * w + x;
        Pixel& p = px[i];
        p.depth = g.depth->at(x, y, 0);
        p.hit = std::isfinite(p.depth);
        p.id = g.ids->at(x, y, 0);
        const float* nm = g.normal->pixel(x, y);
        p.n[0] = nm[0], p.n[1] = nm[1], p.n[2] = nm[2];
        for (int c = 0; c < 3; ++c)
          cur[i * 3 + c] = color.data()[i * 3 + c] / std::max(g.albedo->data()[i * 3 + c], floor);
        lum[i] = luminance(&cur[i * 3]);
      }
    });
    // The depth gradient (largest step to a 4-neighbour of the same object), which sets how much
    // depth may change per pixel along a surface, and the local luminance variance.
    rows([&](int y) {
      for (int x = 0; x < w; ++x) {
        const std::size_t i = static_cast<std::size_t>(y) * w + x;
        Pixel& p = px[i];
        if (!p.hit) continue;
        p.gradient = depth_gradient(px, w, h, x, y);
        var[i] = window_variance(lum, w, h, x, y, r,
                                 [&](std::size_t j) { return px[j].hit && px[j].id == p.id; });
      }
    });
  });

  run_with_threads(o.threads, [&] {
    for (int it = 0; it < o.iterations; ++it) {
      const int step = 1 << it;
      rows([&](int y) {
          for (int x = 0; x < w; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * w + x;
            const Pixel& p = px[i];
            if (!p.hit) {
              for (int c = 0; c < 3; ++c) next[i * 3 + c] = cur[i * 3 + c];
              next_var[i] = var[i];
              continue;
            }
            const float lp = lum[i];
            const float inv_lum = 1.0f / (o.sigma_luminance * std::sqrt(var[i]) + 1e-4f);
            // 1 / (sigma_depth |grad z| distance + 1e-4 z) for each of the six tap distances.
            float inv_depth[6];
            for (int d = 0; d < 6; ++d)
              inv_depth[d] = 1.0f / (o.sigma_depth * p.gradient * kDistances[d] *
                                         static_cast<float>(step) + 1e-4f * p.depth);
            float sum[3] = {0, 0, 0}, wsum = 0, vsum = 0;
            for (int ky = 0; ky < 5; ++ky) {
              const int qy = y + (ky - 2) * step;
              if (qy < 0 || qy >= h) continue;
              for (int kx = 0; kx < 5; ++kx) {
                const int qx = x + (kx - 2) * step;
                if (qx < 0 || qx >= w) continue;
                const std::size_t j = static_cast<std::size_t>(qy) * w + qx;
                const Pixel& q = px[j];
                if (!q.hit || q.id != p.id) continue;
                const float dot =
                    std::max(0.0f, p.n[0] * q.n[0] + p.n[1] * q.n[1] + p.n[2] * q.n[2]);
                // One exponential for the depth and luminance weights together.
                const float e = std::abs(p.depth - q.depth) * inv_depth[kDistanceClass[ky][kx]] +
                                std::abs(lp - lum[j]) * inv_lum;
                const float wgt =
                    kKernel[kx] * kKernel[ky] * power(dot, normal_power) * exp_neg(e);
                for (int c = 0; c < 3; ++c) sum[c] += wgt * cur[j * 3 + c];
                wsum += wgt;
                vsum += wgt * wgt * var[j];
              }
            }
            if (!(wsum > 0.0f)) {  // a degenerate normal: even the centre tap weighs nothing
              for (int c = 0; c < 3; ++c) next[i * 3 + c] = cur[i * 3 + c];
              next_var[i] = var[i];
              continue;
            }
            for (int c = 0; c < 3; ++c) next[i * 3 + c] = sum[c] / wsum;
            next_var[i] = vsum / (wsum * wsum);
          }
      });
      next_iteration(cur, next, var, next_var, lum, w, h);
    }
  });

  image::Image out = color;
  for (std::size_t i = 0; i < n; ++i) {
    if (!px[i].hit) continue;
    for (int c = 0; c < 3; ++c)
      out.data()[i * 3 + c] = cur[i * 3 + c] * std::max(g.albedo->data()[i * 3 + c], floor);
  }
  return out;
}

}  // namespace dofcache::denoise
