#include <cstdio>
#include <filesystem>
#include <memory>

#include "commands.h"
#include "common_options.h"
#include "dofcache/image/image_io.h"
#include "dofcache/preview/refocus_file.h"

namespace dofcache::cli {
namespace {

struct RefocusOptions {
  preview::RefocusFileRequest request;
  std::string out = "refocus.png", method;
  bool quiet = false;
};

int run_refocus(RefocusOptions& o) {
  image::check_output_path(o.out);
  if (!o.method.empty()) o.request.method = preview::parse_preview_method(o.method);
  const preview::RefocusFileResult r = preview::refocus_file(o.request);
  if (!r.warning.empty()) std::fprintf(stderr, "dofcache: warning: %s\n", r.warning.c_str());
  if (!r.lens.aperture.plain())
    std::fprintf(stderr, "dofcache: notice: %s\n", preview::kShapedPreviewNotice);
  image::write_image(o.out, r.image);
  if (!o.quiet)
    std::printf(
        "refocus %dx%d %s, %.0f mm f/%.3g focused at %.3g m, %d layers: load %.1f ms, "
        "post-process %.1f ms\n",
        r.image.width(), r.image.height(), preview::preview_method_name(r.method),
        r.lens.focal_length * 1e3, r.lens.fstop, r.lens.focus_distance, r.layers, r.load_ms,
        r.postprocess_ms);
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
  cmd->add_option("INPUT", o->request.input, "Preview inputs (.exr) saved by 'dofcache render'")
      ->required();
  cmd->add_option("-o,--out", o->out, "Output image: .png (sRGB) or .exr (linear)")
      ->capture_default_str();
  add_lens_options(cmd, o->request.lens, "the saved lens's");
  cmd->add_option("--method", o->method,
                  "preview (Kraus & Strengert's layers), preview-occlusion (with the paper's "
                  "occlusion fix; the default when the file holds revealed layers), "
                  "preview-gather or preview-scatter, as render --mode names them (the older "
                  "names layered, layered-occlusion, gather and scatter are accepted)")
      ->check([](const std::string& name) {
        return preview::find_preview_method(name) ? std::string() : "unknown method '" + name + "'";
      });
  cmd->add_option("--threads", o->request.threads, "Worker threads (0: every core this process may use)")
      ->capture_default_str()
      ->check(CLI::Range(0, 4096));
  add_composite_options(cmd, o->request.composite, o->request.edge_rays);
  cmd->add_option("--max-image-values", o->request.max_image_values,
                  "Refuse inputs whose images (read, and the revealed layers expanded) hold more "
                  "float values (docs/reliability.md)")
      ->capture_default_str()->check(CLI::PositiveNumber);
  cmd->add_flag("-q,--quiet", o->quiet, "Print only the output path");
  return [o] { return run_refocus(*o); };
}

}  // namespace dofcache::cli
