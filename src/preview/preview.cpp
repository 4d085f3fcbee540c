#include "dofcache/preview/preview.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_arena.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <utility>

#include "dofcache/core/error.h"
#include "dofcache/preview/baselines.h"
#include "pipeline.h"

namespace dofcache::preview {

PreviewWorkspace::PreviewWorkspace() : impl_(std::make_unique<Impl>()) {}
PreviewWorkspace::~PreviewWorkspace() = default;

const char* preview_method_name(PreviewMethod method) {
  switch (method) {
    case PreviewMethod::Gather:
      return "gather";
    case PreviewMethod::Scatter:
      return "scatter";
    case PreviewMethod::Layered:
      return "layered";
    case PreviewMethod::LayeredOcclusion:
      return "layered-occlusion";
  }
  return "?";
}

PreviewMethod parse_preview_method(const std::string& name) {
  for (PreviewMethod m : {PreviewMethod::Gather, PreviewMethod::Scatter, PreviewMethod::Layered,
                          PreviewMethod::LayeredOcclusion})
    if (name == preview_method_name(m)) return m;
  throw Error("unknown preview method '" + name +
              "' (expected gather, scatter, layered or layered-occlusion)");
}

namespace {

using Range = std::pair<float, float>;

// The pinhole CoC map into ws.coc; returns its [min, max].
Range compute_coc(const image::Image& depth, const lens::LensImaging& imaging,
                  const PreviewOptions& options, PreviewWorkspace::Impl& ws) {
  const size_t N = depth.pixel_count();
  detail::ensure_size(ws.coc, N);
  CocMap coc(imaging, options.max_coc_radius);
  const float* d = depth.data().data();
  float* c = ws.coc.data();
  Range r = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, N, 4096),
      Range{std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity()},
      [&](const tbb::blocked_range<size_t>& b, Range acc) {
        for (size_t p = b.begin(); p < b.end(); ++p) {
          float v = coc(d[p]);
          c[p] = v;
          acc.first = std::min(acc.first, v);
          acc.second = std::max(acc.second, v);
        }
        return acc;
      },
      [](Range a, Range b) {
        return Range{std::min(a.first, b.first), std::max(a.second, b.second)};
      });
  return N ? r : Range{0.0f, 0.0f};
}

void check_inputs(const image::Image& color, const image::Image& depth) {
  if (color.empty() || color.channels() != 3)
    throw Error("preview: the colour image must be non-empty RGB");
  if (depth.width() != color.width() || depth.height() != color.height() || depth.channels() != 1)
    throw Error("preview: the depth image must be 1 channel of the colour image's size (" +
                std::to_string(color.width()) + "x" + std::to_string(color.height()) + ")");
}

template <class F>
void run_in_arena(int threads, const F& f) {
  if (threads > 0) {
    tbb::task_arena arena(threads);
    arena.execute(f);
  } else {
    f();
  }
}

// CoC at most one pixel wide everywhere: nothing to blur.
bool all_sharp(Range r) { return std::max(std::abs(r.first), std::abs(r.second)) <= 1.0f; }

}  // namespace

image::Image render_preview(const PreviewInputs& inputs, PreviewMethod method,
                            const PreviewOptions& options, PreviewTimings* timings) {
  PreviewWorkspace workspace;
  return render_preview(inputs, method, options, workspace, timings);
}

image::Image render_preview(const PreviewInputs& inputs, PreviewMethod method,
                            const PreviewOptions& options, PreviewWorkspace& workspace,
                            PreviewTimings* timings) {
  using clock = std::chrono::steady_clock;
  auto start = clock::now();
  check_inputs(inputs.color, inputs.depth);
  PreviewTimings t;
  image::Image out;
  PreviewWorkspace::Impl& ws = workspace.impl();
  run_in_arena(options.threads, [&] {
    auto t0 = clock::now();
    Range range = compute_coc(inputs.depth, inputs.imaging, options, ws);
    if (all_sharp(range)) {
      out = inputs.color;
      t.setup_ms = detail::ms_since(t0);
      return;
    }
    out = image::Image(inputs.color.width(), inputs.color.height(), 3);
    if (method == PreviewMethod::Gather || method == PreviewMethod::Scatter) {
      t.setup_ms = detail::ms_since(t0);
      auto t1 = clock::now();
      if (method == PreviewMethod::Gather)
        detail::gather_preview(inputs.color, options, ws, out);
      else
        detail::scatter_preview(inputs.color, options, ws, out);
      t.filter_ms = detail::ms_since(t1);
      return;
    }
    LayerPlan plan = plan_layers_for_range(range.first, range.second, inputs.imaging, options);
    t.setup_ms = detail::ms_since(t0);
    detail::layered_preview(inputs, options, plan, method == PreviewMethod::LayeredOcclusion, ws,
                            out, t);
  });
  t.total_ms = detail::ms_since(start);
  if (timings) *timings = t;
  return out;
}

namespace {
image::Image run_baseline(const image::Image& color, const image::Image& depth,
                          const lens::LensImaging& imaging, const PreviewOptions& options,
                          PreviewMethod method) {
  PreviewInputs in;
  in.color = color;
  in.depth = depth;
  in.imaging = imaging;
  return render_preview(in, method, options);
}
}  // namespace

image::Image gather_blur(const image::Image& color, const image::Image& depth,
                         const lens::LensImaging& imaging, const PreviewOptions& options) {
  return run_baseline(color, depth, imaging, options, PreviewMethod::Gather);
}

image::Image scatter_blur(const image::Image& color, const image::Image& depth,
                          const lens::LensImaging& imaging, const PreviewOptions& options) {
  return run_baseline(color, depth, imaging, options, PreviewMethod::Scatter);
}

}  // namespace dofcache::preview
