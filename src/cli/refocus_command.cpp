#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <utility>

#include "commands.h"
#include "common_options.h"
#include "dofcache/core/error.h"
#include "dofcache/core/stopwatch.h"
#include "dofcache/image/image_io.h"
#include "dofcache/preview/inputs_file.h"
#include "dofcache/preview/refocus.h"

namespace dofcache::cli {
namespace {

struct RefocusOptions {
  std::string input, out = "refocus.png", method;
  render::LensOverrides lens;
  int threads = 0;
  std::uint64_t max_image_values = image::kMaxImageValues;
  preview::LayerComposite composite = preview::LayerComposite::Over;
  int edge_rays = preview::PreviewOptions{}.edge_rays;
  bool quiet = false;
};

int run_refocus(const RefocusOptions& o) {
  image::check_output_path(o.out);
  Stopwatch watch;
  preview::SavedPreviewInputs saved = preview::load_preview_inputs(o.input, o.max_image_values);
  const double load_ms = watch.ms();

  lens::ThinLens lens = saved.inputs.imaging.lens;
  lens.focal_length = o.lens.focal_length.value_or(lens.focal_length);
  lens.fstop = o.lens.fstop.value_or(lens.fstop);
  lens.focus_distance = o.lens.focus_distance.value_or(lens.focus_distance);
  // Without --method: the occlusion fix if the file has revealed layers, else Kraus & Strengert.
  const preview::PreviewMethod method = !o.method.empty() ? preview::parse_preview_method(o.method)
                                        : saved.coverage.present
                                            ? preview::PreviewMethod::LayeredOcclusion
                                            : preview::PreviewMethod::Layered;
  preview::PreviewOptions options = saved.options;
  options.threads = o.threads;
  options.layer_composite = o.composite;
  options.edge_rays = o.edge_rays;

  watch.restart();
  preview::RefocusedInputs in =
      preview::refocus_inputs(std::move(saved.inputs), saved.coverage, lens, options);
  if (method == preview::PreviewMethod::LayeredOcclusion && !in.warning.empty())
    std::fprintf(stderr, "dofcache: warning: %s\n", in.warning.c_str());
  image::Image result = preview::render_preview(in.inputs, method, options);
  const double postprocess_ms = watch.ms();
  image::write_image(o.out, result);
  if (!o.quiet)
    std::printf(
        "refocus %dx%d %s, %.0f mm f/%.3g focused at %.3g m, %d layers: load %.1f ms, "
        "post-process %.1f ms\n",
        result.width(), result.height(), preview::preview_method_name(method),
        lens.focal_length * 1e3, lens.fstop, lens.focus_distance, in.plan.size(), load_ms,
        postprocess_ms);
  std::printf("wrote   %s\n", std::filesystem::absolute(o.out).lexically_normal().c_str());
  return 0;
}

}  // namespace

Runner add_refocus_command(CLI::App& app) {
  auto o = std::make_shared<RefocusOptions>();
  CLI::App* cmd = app.add_subcommand(
      "refocus",
      "Rerun only the preview post-process on inputs saved by 'dofcache render --mode preview... "
      "--save-preview-inputs', with another lens.");
  cmd->add_option("INPUT", o->input, "Preview inputs (.exr) saved by 'dofcache render'")
      ->required();
  cmd->add_option("-o,--out", o->out, "Output image: .png (sRGB) or .exr (linear)")
      ->capture_default_str();
  add_lens_options(cmd, o->lens, "the saved lens's");
  cmd->add_option("--method", o->method,
                  "preview (Kraus & Strengert's layers), preview-occlusion (with the paper's "
                  "occlusion fix; the default when the file holds revealed layers), "
                  "preview-gather or preview-scatter, as render --mode names them (the older "
                  "names layered, layered-occlusion, gather and scatter are accepted)")
      ->check([](const std::string& name) {
        return preview::find_preview_method(name) ? std::string() : "unknown method '" + name + "'";
      });
  cmd->add_option("--threads", o->threads, "Worker threads (0: every core this process may use)")
      ->capture_default_str()
      ->check(CLI::Range(0, 4096));
  add_composite_options(cmd, o->composite, o->edge_rays);
  cmd->add_option("--max-image-values", o->max_image_values,
                  "Refuse inputs whose images (read, and the revealed layers expanded) hold more "
                  "float values (docs/reliability.md)")
      ->capture_default_str()->check(CLI::PositiveNumber);
  cmd->add_flag("-q,--quiet", o->quiet, "Print only the output path");
  return [o] { return run_refocus(*o); };
}

}  // namespace dofcache::cli
