// Post-process cost of the depth-of-field preview methods (gather, scatter, layered, layered with
// the occlusion fix, with and without its edge trace) on the synthetic demo scene
// (preview/synthetic_scene.h: a textured backdrop behind the focal plane, a receding floor, boxes
// from 0.8 m to 6 m; 50 mm f/1.4 focused at 3 m, so CoC radii span about -13 .. +5 px at 480 rows,
// scaled with the height), at 640x480 and 1280x720, with 1 and 2 threads. Also the occlusion-mask
// construction (build_occlusion_masks), which the paper counts separately ("extra-region mask").
// Inputs, near-plane id layers and revealed layers are made once per resolution, outside the
// timing.
//
//   preview_postprocess_bench [--results NAME] [--benchmark_NAME=VALUE...]   (--help for more)
//
// Prints a summary table (wall time per call: the mean over the benchmark's iterations and the
// fastest call, and the mean per-stage split from PreviewTimings) and writes
// bench/results/preview_postprocess.{json,csv}. On a shared machine the mean includes time lost to
// other processes; "min" is the better estimate of the cost itself.
#include <benchmark/benchmark.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

#include "dofcache/core/stopwatch.h"
#include "bench_common.h"
#include "dofcache/preview/occlusion.h"
#include "dofcache/preview/preview.h"
#include "dofcache/preview/synthetic_scene.h"

using namespace dofcache;
using namespace dofcache::preview;

namespace {

struct Resolution {
  int width, height;
};
const Resolution kResolutions[] = {{640, 480}, {1280, 720}};

struct Scene {
  SyntheticScene scene;
  PreviewInputs inputs;  // with the revealed layers
  LayerPlan plan;
  std::vector<image::Image> id_layers;
};

const Scene& scene_for(int resolution) {
  static std::map<int, std::unique_ptr<Scene>> scenes;
  auto& s = scenes[resolution];
  if (!s) {
    s = std::make_unique<Scene>();
    const Resolution r = kResolutions[resolution];
    s->scene = make_demo_scene(r.width, r.height);
    s->inputs = s->scene.pinhole();
    PreviewOptions options;
    s->plan = plan_layers(s->inputs.depth, s->inputs.imaging, options);
    s->id_layers = s->scene.id_layers(s->plan);
    std::vector<image::Image> masks =
        build_occlusion_masks(s->id_layers, s->inputs.depth, s->plan, s->inputs.imaging, options);
    s->inputs.revealed = s->scene.revealed_layers(s->plan, masks);
  }
  return *s;
}

// Sums of the per-stage timings of one benchmark run, for the summary.
struct Row {
  std::string method;
  int width = 0, height = 0, threads = 0;
  double min_ms = 1e300;  // fastest call: the cost without interference from other processes
  PreviewTimings sum;
  long calls = 0;
};
std::map<std::tuple<std::string, int, int>, Row> g_rows;

void add(PreviewTimings& a, const PreviewTimings& b) {
  a.setup_ms += b.setup_ms;
  a.fill_ms += b.fill_ms;
  a.matting_ms += b.matting_ms;
  a.blur_blend_ms += b.blur_blend_ms;
  a.filter_ms += b.filter_ms;
  a.resolve_ms += b.resolve_ms;
  a.trace_ms += b.trace_ms;
  a.total_ms += b.total_ms;
  a.layers = b.layers;
  a.layers_blurred = b.layers_blurred;
}

void BM_Preview(benchmark::State& state, PreviewMethod method, PreviewOptions options,
                std::string label) {
  const int resolution = static_cast<int>(state.range(0));
  const int threads = static_cast<int>(state.range(1));
  const Scene& s = scene_for(resolution);
  options.threads = threads;
  PreviewWorkspace workspace;
  render_preview(s.inputs, method, options, workspace);  // warm the workspace
  Row row;
  row.method = label;
  row.width = s.inputs.color.width();
  row.height = s.inputs.color.height();
  row.threads = threads;
  for (auto _ : state) {
    PreviewTimings t;
    image::Image out = render_preview(s.inputs, method, options, workspace, &t);
    benchmark::DoNotOptimize(out.data().data());
    add(row.sum, t);
    row.min_ms = std::min(row.min_ms, t.total_ms);
    ++row.calls;
  }
  state.counters["layers"] = row.sum.layers;
  state.SetLabel(std::to_string(row.width) + "x" + std::to_string(row.height));
  g_rows[{row.method, row.height, threads}] = row;
}

void BM_Masks(benchmark::State& state) {
  const int resolution = static_cast<int>(state.range(0));
  const int threads = static_cast<int>(state.range(1));
  const Scene& s = scene_for(resolution);
  PreviewOptions options;
  tbb::task_arena arena(threads);
  Row row;
  row.method = "occlusion masks";
  row.width = s.inputs.color.width();
  row.height = s.inputs.color.height();
  row.threads = threads;
  for (auto _ : state) {
    auto start = std::chrono::steady_clock::now();
    arena.execute([&] {
      benchmark::DoNotOptimize(
          build_occlusion_masks(s.id_layers, s.inputs.depth, s.plan, s.inputs.imaging, options));
    });
    double ms = ms_since(start);
    row.sum.total_ms += ms;
    row.min_ms = std::min(row.min_ms, ms);
    ++row.calls;
  }
  row.sum.layers = s.plan.size();
  state.SetLabel(std::to_string(row.width) + "x" + std::to_string(row.height));
  g_rows[{row.method, row.height, threads}] = row;
}

// The 1-minute load average: on a shared machine, what else competed for the cores.
double load_average() {
  double load = -1;
  if (std::FILE* f = std::fopen("/proc/loadavg", "r")) {
    if (std::fscanf(f, "%lf", &load) != 1) load = -1;
    std::fclose(f);
  }
  return load;
}

int run(const std::string& results_name) {
  const double load_before = load_average();
  // Each method with the default options, the layered methods with slabs too, and the occlusion
  // fix without its edge trace.
  PreviewOptions slabs, layers_only;
  slabs.layer_composite = LayerComposite::Slabs;
  layers_only.edge_rays = 0;
  const std::vector<std::tuple<PreviewMethod, PreviewOptions, std::string>> variants = {
      {PreviewMethod::Gather, {}, "gather"},
      {PreviewMethod::Scatter, {}, "scatter"},
      {PreviewMethod::Layered, {}, "layered"},
      {PreviewMethod::Layered, slabs, "layered, slabs"},
      {PreviewMethod::LayeredOcclusion, {}, "layered-occlusion"},
      {PreviewMethod::LayeredOcclusion, layers_only, "layered-occlusion, layers only"},
      {PreviewMethod::LayeredOcclusion, slabs, "layered-occlusion, slabs"}};
  for (const auto& [m, opts, label] : variants) {
    benchmark::RegisterBenchmark(label.c_str(), BM_Preview, m, opts, label)
        ->ArgsProduct({{0, 1}, {1, 2}})
        ->ArgNames({"res", "threads"})
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime()
        ->MinTime(1.0);
  }
  benchmark::RegisterBenchmark("occlusion_masks", BM_Masks)
      ->ArgsProduct({{0, 1}, {1, 2}})
      ->ArgNames({"res", "threads"})
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  const double load_after = load_average();
  if (g_rows.empty()) {  // --benchmark_list_tests, or a filter that matched nothing
    std::printf("no benchmark ran: %s not written\n", results_name.c_str());
    return 0;
  }

  bench::Table table(
      {"method", "resolution", "threads", "layers", "total [ms]", "min [ms]", "setup [ms]",
       "fill [ms]", "matting [ms]", "blur+blend [ms]", "filter [ms]", "resolve [ms]",
       "edge trace [ms]"},
      2);
  for (const auto& [key, r] : g_rows) {
    if (!r.calls) continue;
    const double n = static_cast<double>(r.calls);
    table.add_row({r.method, std::to_string(r.width) + "x" + std::to_string(r.height), r.threads,
                   r.sum.layers, r.sum.total_ms / n, r.min_ms, r.sum.setup_ms / n,
                   r.sum.fill_ms / n, r.sum.matting_ms / n, r.sum.blur_blend_ms / n,
                   r.sum.filter_ms / n, r.sum.resolve_ms / n, r.sum.trace_ms / n});
  }
  table.print();
  std::printf("load average (1 min): %.2f before, %.2f after\n", load_before, load_after);
  nlohmann::json results = {{"scene", "make_demo_scene (preview/synthetic_scene.h)"},
                            {"timing", "wall clock per call: mean and min over the iterations"},
                            {"load_average_before", load_before},
                            {"load_average_after", load_after},
                            {"columns", table.header()},
                            {"rows", table.to_json()}};
  std::printf("wrote %s\n", bench::write_results(results_name, results).c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::string results = "preview_postprocess";
  CLI::App app{"Post-process cost of the depth-of-field preview methods on the synthetic demo "
               "scene, at 640x480 and 1280x720 with 1 and 2 threads.",
               "preview_postprocess_bench"};
  bench::add_results_option(app, results);
  bench::parse_benchmark_command_line(app, argc, argv);
  return bench::run_guarded(app, [&] { return run(results); });
}
