#include "dofcache/preview/layers.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "matting_kernel.h"

namespace dofcache::preview {

CocMap::CocMap(const lens::LensImaging& imaging, double max_coc_radius)
    : focus_(imaging.lens.focus_distance), limit_(2.0 * max_coc_radius) {
  // Same k as LensImaging::depth_for_signed_coc: c(D) = k (D - P) / D.
  double aperture = imaging.lens.aperture_diameter();
  k_ = aperture > 0 ? aperture * imaging.lens.film_distance() /
                          (imaging.lens.focus_distance * imaging.pixel_pitch())
                    : 0.0;
}

LayerPlan plan_layers(const image::Image& depth, const lens::LensImaging& imaging,
                      const PreviewOptions& options) {
  CocMap coc(imaging, options.max_coc_radius);
  const float* d = depth.data().data();
  using Range = std::pair<float, float>;
  Range r = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, depth.pixel_count(), 4096),
      Range{std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity()},
      [&](const tbb::blocked_range<size_t>& b, Range acc) {
        for (size_t p = b.begin(); p < b.end(); ++p) {
          float c = coc(d[p]);
          acc.first = std::min(acc.first, c);
          acc.second = std::max(acc.second, c);
        }
        return acc;
      },
      [](Range a, Range b) {
        return Range{std::min(a.first, b.first), std::max(a.second, b.second)};
      });
  if (r.first > r.second) r = {0.0f, 0.0f};  // empty image
  return plan_layers_for_range(r.first, r.second, imaging, options);
}

LayerPlan plan_layers_for_range(double coc_min, double coc_max, const lens::LensImaging& imaging,
                                const PreviewOptions& options) {
  const double limit = 2.0 * options.max_coc_radius;
  if (coc_min > coc_max) std::swap(coc_min, coc_max);
  coc_min = std::clamp(coc_min, -limit, limit);
  coc_max = std::clamp(coc_max, -limit, limit);

  LayerPlan plan;
  plan.coc_min = coc_min;
  plan.coc_max = coc_max;
  plan.origin = coc_min;
  const double span = coc_max - coc_min;  // signed CoC (diameter)
  const int cap = std::clamp(options.max_layers, 1, 64);
  int n = 1;
  if (span > 1e-9 && options.layer_count > 0) {
    n = std::min(options.layer_count, 64);
    plan.step = n > 1 ? span / (n - 1) : 0.0;
  } else if (span > 1e-9 && cap >= 3) {
    double sharpest =
        (coc_min <= 0 && coc_max >= 0) ? 0.0 : 0.5 * std::min(std::abs(coc_min), std::abs(coc_max));
    double step = 2.0 * std::max({options.min_layer_step, (std::sqrt(2.0) - 1.0) * sharpest, 1e-6});
    step = std::max(step, span / (cap - 2));
    const double k_lo = std::floor(coc_min / step), k_hi = std::ceil(coc_max / step);
    n = static_cast<int>(k_hi - k_lo) + 1;
    plan.origin = k_lo * step;
    plan.step = step;
  } else if (span > 1e-9 && cap == 2) {
    n = 2;
    plan.step = span;
  }
  plan.layers.resize(n);
  for (int i = 0; i < n; ++i) {
    PreviewLayer& l = plan.layers[i];
    l.signed_coc = plan.anchor(i);
    if (options.layer_count > 0 || cap < 3) {  // end anchors exactly at the range ends
      if (i == n - 1 && n > 1) l.signed_coc = coc_max;
    }
    l.depth = imaging.depth_for_signed_coc(l.signed_coc);
    l.blur_radius = 0.5 * std::abs(l.signed_coc);
  }
  return plan;
}

namespace {
detail::Matte matte_of(const LayerPlan& plan, int i) {
  detail::Matte m;
  m.c0 = static_cast<float>(plan.origin);
  m.inv_step = plan.step > 0 ? static_cast<float>(1.0 / plan.step) : 0.0f;
  m.i = i;
  m.n = plan.size();
  return m;
}
}  // namespace

float matting_weight(const LayerPlan& plan, int i, double c) {
  return matte_of(plan, i).weight(static_cast<float>(c));
}

float revealed_matting_weight(const LayerPlan& plan, int i, double c) {
  return matte_of(plan, i).revealed_weight(static_cast<float>(c));
}

float hat_weight(const LayerPlan& plan, int i, double c) {
  detail::Matte m = matte_of(plan, i);
  m.part = detail::MattePart::NearHalf;
  const float near = m.weight(static_cast<float>(c));
  m.part = detail::MattePart::FarHalf;
  return near + m.weight(static_cast<float>(c));
}

double composite_coverage(const LayerPlan& plan, double c) {
  double covered = 0, transmitted = 1;
  for (int i = 0; i < plan.size(); ++i) {
    double w = matting_weight(plan, i, c);
    covered += transmitted * w;
    transmitted *= 1.0 - w;
  }
  return covered;
}

}  // namespace dofcache::preview
