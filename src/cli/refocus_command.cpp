#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <utility>

#include "commands.h"
#include "common_options.h"
#include "dofcache/core/error.h"
#include "dofcache/image/image_io.h"
#include "dofcache/preview/inputs_file.h"
#include "dofcache/preview/refocus.h"

namespace dofcache::cli {
namespace {

struct RefocusOptions {
  std::string input, out = "refocus.png", method;
  std::optional<double> fstop, focal_length, focus_distance;  // add_lens_options
  int threads = 0;
  std::uint64_t max_image_values = image::kMaxImageValues;
  preview::PreviewOptions composite;  // only layer_composite and edge_rays are set from flags
  bool quiet = false;
};

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

int run_refocus(const RefocusOptions& o) {
  image::check_output_path(o.out);
  auto t0 = std::chrono::steady_clock::now();
  preview::SavedPreviewInputs saved = preview::load_preview_inputs(o.input, o.max_image_values);
  const double load_ms = ms_since(t0);

  lens::ThinLens lens = saved.inputs.imaging.lens;
  if (o.focal_length) lens.focal_length = *o.focal_length;
  if (o.fstop) lens.fstop = *o.fstop;
  if (o.focus_distance) lens.focus_distance = *o.focus_distance;
  // Without --method: the occlusion fix if the file has revealed layers, else Kraus & Strengert.
  const preview::PreviewMethod method = !o.method.empty() ? preview::parse_preview_method(o.method)
                                        : saved.coverage.present
                                            ? preview::PreviewMethod::LayeredOcclusion
                                            : preview::PreviewMethod::Layered;
  preview::PreviewOptions options = saved.options;
  options.threads = o.threads;
  apply_composite_options(o.composite, options);

  t0 = std::chrono::steady_clock::now();
  preview::RefocusedInputs in =
      preview::refocus_inputs(std::move(saved.inputs), saved.coverage, lens, options);
  if (method == preview::PreviewMethod::LayeredOcclusion && !in.warning.empty())
    std::fprintf(stderr, "dofcache: warning: %s\n", in.warning.c_str());
  image::Image result = preview::render_preview(in.inputs, method, options);
  const double postprocess_ms = ms_since(t0);
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
  add_lens_options(cmd, o->fstop, o->focal_length, o->focus_distance, "the saved lens's");
  cmd->add_option("--method", o->method,
                  "layered (Kraus & Strengert), layered-occlusion (with the paper's occlusion fix; "
                  "the default when the file holds revealed layers), gather or scatter")
      ->check(CLI::IsMember({"layered", "layered-occlusion", "gather", "scatter"}));
  cmd->add_option("--threads", o->threads, "Worker threads (0: all cores)")
      ->capture_default_str()
      ->check(CLI::Range(0, 4096));
  add_composite_options(cmd, o->composite);
  cmd->add_option("--max-image-values", o->max_image_values,
                  "Refuse inputs whose images (read, and the revealed layers expanded) hold more "
                  "float values (docs/reliability.md)")
      ->capture_default_str()->check(CLI::PositiveNumber);
  cmd->add_flag("-q,--quiet", o->quiet, "Print only the output path");
  return [o] { return run_refocus(*o); };
}

}  // namespace dofcache::cli
