#include "dofcache/preview/preview.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_arena.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <utility>

#include "dofcache/core/error.h"
#include "dofcache/core/threads.h"
#include "dofcache/preview/baselines.h"
#include "pipeline.h"

namespace dofcache::preview {

PreviewWorkspace::PreviewWorkspace() : impl_(std::make_unique<Impl>()) {}
PreviewWorkspace::~PreviewWorkspace() = default;

namespace {

// The one name table of the methods: the names `render --mode` spells, and the older names that
// `refocus --method` and saved viewer state used, still accepted.
struct MethodName {
  PreviewMethod method;
  const char* name;
  const char* old_name;
  const char* label;  // for people (the viewer's menu)
};
constexpr MethodName kMethodNames[] = {
    {PreviewMethod::Layered, "preview", "layered", "Kraus & Strengert (layered)"},
    {PreviewMethod::LayeredOcclusion, "preview-occlusion", "layered-occlusion",
     "occlusion fix (layered + revealed layers)"},
    {PreviewMethod::Gather, "preview-gather", "gather", "gather"},
    {PreviewMethod::Scatter, "preview-scatter", "scatter", "scatter"},
};

}  // namespace

const char* preview_method_name(PreviewMethod method) {
  for (const MethodName& m : kMethodNames)
    if (m.method == method) return m.name;
  return "?";
}

const char* preview_method_label(PreviewMethod method) {
  for (const MethodName& m : kMethodNames)
    if (m.method == method) return m.label;
  return "?";
}

std::optional<PreviewMethod> find_preview_method(const std::string& name) {
  for (const MethodName& m : kMethodNames)
    if (name == m.name || name == m.old_name) return m.method;
  return std::nullopt;
}

PreviewMethod parse_preview_method(const std::string& name) {
  if (auto m = find_preview_method(name)) return *m;
  throw Error("unknown preview method '" + name +
              "' (expected preview, preview-occlusion, preview-gather or preview-scatter)");
}

const std::vector<std::string>& preview_method_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (const MethodName& m : kMethodNames) n.push_back(m.name);
    return n;
  }();
  return names;
}

const char* layer_composite_name(LayerComposite composite) {
  return composite == LayerComposite::Slabs ? "slabs" : "over";
}

const char* layer_composite_label(LayerComposite composite) {
  return composite == LayerComposite::Slabs ? "slabs (hat mattes split at the anchors)"
                                            : "over (Kraus & Strengert)";
}

LayerComposite parse_layer_composite(const std::string& name) {
  if (name == "over") return LayerComposite::Over;
  if (name == "slabs") return LayerComposite::Slabs;
  throw Error("unknown layer composite '" + name + "' (expected over or slabs)");
}

const std::vector<std::string>& layer_composite_names() {
  static const std::vector<std::string> names = {"over", "slabs"};
  return names;
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
  run_with_threads(options.threads, [&] {
    auto t0 = clock::now();
    Range range = compute_coc(inputs.depth, inputs.imaging, options, ws);
    if (!inputs.imaging.lens.aperture.plain()) {
      // A shaped lens: its bokeh by the shaped scatter, whatever the method (preview.h).
      out = image::Image(inputs.color.width(), inputs.color.height(), 3);
      t.setup_ms = ms_since(t0);
      auto t1 = clock::now();
      // With the occlusion fix, the surfaces it revealed are splatted too.
      const bool fix = method == PreviewMethod::LayeredOcclusion;
      t.revealed_fragments =
          static_cast<long>(detail::shaped_scatter_preview(inputs, options, fix, ws, out));
      t.revealed_layers = fix ? static_cast<int>(inputs.revealed.size()) : 0;
      t.filter_ms = ms_since(t1);
      t.shaped_bokeh = true;
      return;
    }
    if (all_sharp(range)) {
      out = inputs.color;
      t.setup_ms = ms_since(t0);
      return;
    }
    out = image::Image(inputs.color.width(), inputs.color.height(), 3);
    if (method == PreviewMethod::Gather || method == PreviewMethod::Scatter) {
      t.setup_ms = ms_since(t0);
      auto t1 = clock::now();
      if (method == PreviewMethod::Gather)
        detail::gather_preview(inputs.color, options, ws, out);
      else
        detail::scatter_preview(inputs.color, options, ws, out);
      t.filter_ms = ms_since(t1);
      return;
    }
    LayerPlan plan = plan_layers_for_range(range.first, range.second, inputs.imaging, options);
    t.setup_ms = ms_since(t0);
    detail::layered_preview(inputs, options, plan, method == PreviewMethod::LayeredOcclusion, ws,
                            out, t);
  });
  t.total_ms = ms_since(start);
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
