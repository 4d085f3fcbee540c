#include "dofcache/denoise/render_filter.h"

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
  bool active = false;   // some lens sample hit a surface
  bool sharp = false;    // circle of confusion under focus_coc_pixels
  int normal_power = 1;  // the normal weight's exponent here
  float depth = 0, gradient = 0, id = -1;
  float n[3] = {0, 0, 0};  // the averaged normal, made unit length (0 if it averages to nothing)
};

// A tap's weight besides the spline and the luminance step: factor * exp(-exponent).
struct Tap {
  float factor = 1.0f, exponent = 0.0f;
};

}  // namespace

image::Image coc_radius_image(const image::Image& centre_depth, const image::Image& lens_depth,
                              const lens::LensImaging& imaging) {
  if (centre_depth.channels() != 1 || lens_depth.channels() != 1 ||
      centre_depth.width() != lens_depth.width() || centre_depth.height() != lens_depth.height())
    throw Error("denoise: the depths must be 1-channel images of one size");
  image::Image coc(centre_depth.width(), centre_depth.height(), 1, 0.0f);
  for (std::size_t i = 0; i < coc.pixel_count(); ++i) {
    double r = 0.0;
    for (float z : {centre_depth.data()[i], lens_depth.data()[i]})
      if (std::isfinite(z) && z > 0.0f) r = std::max(r, imaging.coc_radius_pixels(z));
    coc.data()[i] = static_cast<float>(r);
  }
  return coc;
}

image::Image render_filter(const image::Image& color, const RenderGuides& g,
                           const RenderFilterOptions& o) {
  if (color.empty() || color.channels() != 3)
    throw Error("denoise: the colour must be a non-empty RGB image");
  check_guide(g.albedo, color, 3, "albedo");
  check_guide(g.albedo_estimate, color, 3, "albedo estimate");
  check_guide(g.normal, color, 3, "normal");
  check_guide(g.coverage, color, 1, "coverage");
  check_guide(g.emission, color, 3, "emission");
  check_guide(g.emission_estimate, color, 3, "emission estimate");
  check_guide(g.emission_variance, color, 1, "emission variance");
  check_guide(g.variance, color, 1, "variance");
  check_guide(g.depth, color, 1, "depth");
  check_guide(g.ids, color, 1, "id");
  check_guide(g.coc, color, 1, "circle of confusion");
  if (o.iterations < 0 || o.iterations > 10 || !(o.albedo_floor > 0.0f) ||
      !(o.sigma_luminance > 0.0f) || !(o.sigma_depth > 0.0f) || !(o.sigma_normal >= 1.0f) ||
      !(o.focus_coc_pixels >= 0.0f))
    throw Error("denoise: absurd filter options");
  const int w = color.width(), h = color.height();
  const std::size_t n = static_cast<std::size_t>(w) * h;
  std::vector<Pixel> px(n);
  std::vector<float> cur(n * 3), raw_var(n), var(n), lum(n), scale(n * 3);
  auto rows = [h](const auto& f) { for_rows(h, f); };
  auto index = [w](int x, int y) { return static_cast<std::size_t>(y) * w + x; };

  run_with_threads(o.threads, [&] {
    // The guides per pixel; the demodulated colour, its luminance and its noise.
    rows([&](int y) {
      for (int x = 0; x < w; ++x) {
        const std::size_t i = index(x, y);
        Pixel& p = px[i];
        p.active = g.coverage->data()[i] > 0.0f;
        const float coc = g.coc->data()[i];
        p.sharp = coc < o.focus_coc_pixels;
        p.normal_power = std::max(1, static_cast<int>(std::lround(o.sigma_normal / (1.0f + coc))));
        p.depth = g.depth->data()[i];
        p.id = g.ids->data()[i];
        const float* nm = g.normal->pixel(x, y);
        const float len = std::sqrt(nm[0] * nm[0] + nm[1] * nm[1] + nm[2] * nm[2]);
        if (len > 1e-6f)
          for (int c = 0; c < 3; ++c) p.n[c] = nm[c] / len;
        for (int c = 0; c < 3; ++c) {
          scale[i * 3 + c] = std::max(g.albedo->data()[i * 3 + c], o.albedo_floor);
          cur[i * 3 + c] =
              (color.data()[i * 3 + c] - g.emission->data()[i * 3 + c]) / scale[i * 3 + c];
        }
        lum[i] = luminance(&cur[i * 3]);
        const float s = luminance(&scale[i * 3]);
        const float v = g.variance->data()[i] / (s * s);
        raw_var[i] = std::isfinite(v) && v > 0.0f ? v : 0.0f;
      }
    });
    // The depth gradient of sharp pixels (the largest step to a 4-neighbour of the same object,
    // through the centres) and the noise blurred over the 3x3 active neighbours.
    rows([&](int y) {
      for (int x = 0; x < w; ++x) {
        const std::size_t i = index(x, y);
        Pixel& p = px[i];
        if (!p.active) continue;
        p.gradient = depth_gradient(px, w, h, x, y);
        float sum = 0.0f, wsum = 0.0f;
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const int qx = x + dx, qy = y + dy;
            if (qx < 0 || qy < 0 || qx >= w || qy >= h || !px[index(qx, qy)].active) continue;
            const float k = kKernel[dx + 2] * kKernel[dy + 2];
            sum += k * raw_var[index(qx, qy)], wsum += k;
          }
        var[i] = sum / wsum;
        // One sample per pixel measures no noise: the local spread of the demodulated luminance
        // over the 5x5 active pixels of the same object stands in (the quick look's estimate).
        if (var[i] == 0.0f)
          var[i] = window_variance(lum, w, h, x, y, 2,
                                   [&](std::size_t j) { return px[j].active && px[j].id == p.id; });
      }
    });
  });

  // Outliers the measured noise misses: a radiance cache shares its samples between the lens
  // rays of neighbouring pixels, so a bright sample (a few gather rays that met the patch beside
  // a lamp) lights a small spot whose every pixel measured little noise. A pixel further from
  // the median of its 3x3 active neighbours than 3 measured deviations takes that distance as
  // 3 deviations: it then joins its surroundings, which still refuse it. A straight edge keeps
  // its own side in its median and is left alone.
  {
    std::vector<float> robust = var;
    run_with_threads(o.threads, [&] {
      rows([&](int y) {
        float window[9];
        for (int x = 0; x < w; ++x) {
          const std::size_t i = index(x, y);
          if (!px[i].active) continue;
          int count = 0;
          for (int qy = std::max(0, y - 1); qy <= std::min(h - 1, y + 1); ++qy)
            for (int qx = std::max(0, x - 1); qx <= std::min(w - 1, x + 1); ++qx)
              if (px[index(qx, qy)].active) window[count++] = lum[index(qx, qy)];
          std::nth_element(window, window + count / 2, window + count);
          const float d = lum[i] - window[count / 2];
          robust[i] = std::max(var[i], d * d / 9.0f);
        }
      });
    });
    var.swap(robust);
  }

  // `iterations` a-trous passes over `value` (RGB) with its luminance `lum` and the variance of
  // that luminance `variance` (propagated as var' = sum w^2 var / (sum w)^2). Pixels where
  // `takes_part` is false keep their value and give none; tap(i, j, kx, ky, step) is a tap's
  // weight besides the B3 spline and the luminance step measured against the noise, as a factor
  // and an exponent e (the weight takes exp(-e): one exponential per tap). The step is measured
  // against the pixel's own noise. With `sparse`, where one of the two pixels has no measured
  // noise (all its samples alike: a lamp's bokeh where no lens ray met the lamp, or where every
  // one did; the dark beyond its rim), both weigh each other by the chance that its samples saw
  // the other's mean by chance, exp(-step^2 / the noisy one's variance): a rare event of mean m
  // and variance v of the mean is met about m^2 / v times in that many samples, and none with
  // probability exp(-m^2 / v). Such pairs weigh each other alike, so light one gives up the
  // other takes.
  std::vector<float> next_value(n * 3), next_variance(n);
  auto iterate = [&](std::vector<float>& value, std::vector<float>& variance,
                     std::vector<float>& luma, const auto& takes_part, const auto& tap,
                     bool sparse = false) {
    run_with_threads(o.threads, [&] {
      for (int it = 0; it < o.iterations; ++it) {
        const int step = 1 << it;
        rows([&](int y) {
          for (int x = 0; x < w; ++x) {
            const std::size_t i = index(x, y);
            auto keep = [&] {
              for (int c = 0; c < 3; ++c) next_value[i * 3 + c] = value[i * 3 + c];
              next_variance[i] = variance[i];
            };
            // No measured noise: every other value is refused (to float precision), so the pixel
            // keeps its own.
            if (!takes_part(i) || (!sparse && !(variance[i] > 0.0f))) {
              keep();
              continue;
            }
            const float lp = luma[i];
            const float inv_lum =
                1.0f / (o.sigma_luminance * std::sqrt(variance[i]) + 1e-6f * (lp + 1e-3f));
            float sum[3] = {0, 0, 0}, wsum = 0, vsum = 0;
            for (int ky = 0; ky < 5; ++ky) {
              const int qy = y + (ky - 2) * step;
              if (qy < 0 || qy >= h) continue;
              for (int kx = 0; kx < 5; ++kx) {
                const int qx = x + (kx - 2) * step;
                if (qx < 0 || qx >= w) continue;
                const std::size_t j = index(qx, qy);
                if (!takes_part(j)) continue;
                const Tap t = j == i ? Tap{} : tap(i, j, kx, ky, step);
                if (!(t.factor > 0.0f)) continue;
                const float step_lum = std::abs(lp - luma[j]);
                float e;
                if (variance[i] > 0.0f && (!sparse || variance[j] > 0.0f))
                  e = step_lum * inv_lum;
                else if (variance[i] > 0.0f || variance[j] > 0.0f)  // sparse: one is sure
                  e = step_lum * step_lum / std::max(variance[i], variance[j]);
                else
                  e = step_lum > 0.0f ? 1e30f : 0.0f;
                const float wgt =
                    kKernel[kx] * kKernel[ky] * t.factor * exp_neg(e + t.exponent);
                for (int c = 0; c < 3; ++c) sum[c] += wgt * value[j * 3 + c];
                wsum += wgt;
                vsum += wgt * wgt * variance[j];
              }
            }
            if (!(wsum > 0.0f)) {
              keep();
              continue;
            }
            for (int c = 0; c < 3; ++c) next_value[i * 3 + c] = sum[c] / wsum;
            next_variance[i] = vsum / (wsum * wsum);
          }
        });
        next_iteration(value, next_value, variance, next_variance, luma, w, h);
      }
    });
  };

  // The reflected light: the guides and the measured noise decide each tap.
  auto reflected_tap = [&](std::size_t i, std::size_t j, int kx, int ky, int step) {
    const Pixel& p = px[i];
    const Pixel& q = px[j];
    if (!q.active) return Tap{0.0f, 0.0f};
    float e = 0.0f;
    if (p.sharp && q.sharp) {  // an in-focus edge: the centres' ids and depths hold
      if (q.id != p.id) return Tap{0.0f, 0.0f};
      e = std::abs(p.depth - q.depth) /
          (o.sigma_depth * p.gradient * kDistances[kDistanceClass[ky][kx]] *
               static_cast<float>(step) + 1e-4f * p.depth);
    }
    const bool unknown = (p.n[0] == 0 && p.n[1] == 0 && p.n[2] == 0) ||
                         (q.n[0] == 0 && q.n[1] == 0 && q.n[2] == 0);
    const float dot = p.n[0] * q.n[0] + p.n[1] * q.n[1] + p.n[2] * q.n[2];
    const float wn = unknown ? 1.0f : power(std::max(0.0f, dot), p.normal_power);
    return Tap{wn, e};
  };
  iterate(cur, var, lum, [&](std::size_t i) { return px[i].active; }, reflected_tap);

  // The emission (lamps, the sky): its noise is which lamp or sky the lens and film samples met,
  // so only its own measured noise steers, and no tap reaches beyond the pixel's circle of
  // confusion (an in-focus lamp's edge stays as sharp as the film made it). It is sparse: a
  // small lamp's bokeh seen by few lens rays leaves many of its pixels without a hit and without
  // measured noise; sure of their zero they refused their neighbours' light while those averaged
  // it away (a small lamp's bokeh lost half its light at 16 spp).
  std::vector<float> emit(n * 3), emit_lum(n), emit_var(n);
  for (std::size_t i = 0; i < n; ++i) {
    for (int c = 0; c < 3; ++c) emit[i * 3 + c] = g.emission_estimate->data()[i * 3 + c];
    emit_lum[i] = luminance(&emit[i * 3]);
    const float v = g.emission_variance->data()[i];
    emit_var[i] = std::isfinite(v) && v > 0.0f ? v : 0.0f;
  }
  iterate(emit, emit_var, emit_lum, [&](std::size_t) { return true; },
          [&](std::size_t i, std::size_t, int, int, int step) {
            return Tap{static_cast<float>(step) <= std::max(1.0f, g.coc->data()[i]) ? 1.0f : 0.0f,
                       0.0f};
          },
          true);

  image::Image out = color;
  for (std::size_t i = 0; i < n; ++i) {
    const float* e = &emit[i * 3];
    // Divided by the albedo of the colour's own samples, whose share of each surface the colour
    // follows; multiplied by the better estimate of that albedo.
    for (int c = 0; c < 3; ++c)
      out.data()[i * 3 + c] = px[i].active
                                  ? cur[i * 3 + c] *
                                            std::max(g.albedo_estimate->data()[i * 3 + c],
                                                     o.albedo_floor) +
                                        e[c]
                                           : color.data()[i * 3 + c] -
                                                 g.emission->data()[i * 3 + c] + e[c];
  }
  return out;
}

}  // namespace dofcache::denoise
