#include <cstdio>
#include <filesystem>
#include <memory>

#include "commands.h"
#include "common_options.h"
#include "dofcache/cache/radiance_cache.h"
#include "dofcache/request/image_render.h"
#include "dofcache/request/resolve.h"
#include "dofcache/scene/accel.h"

namespace dofcache::cli {
namespace {

struct RenderOptions {
  request::RenderRequest request = request::default_request(request::Kind::Image);
  RequestFileOptions file;
};

int run_render(const request::RenderRequest& q, bool print_request) {
  if (!print_request) request::check_image_request(q);  // before loading the scene
  scene::Scene scene = render::load_scene(q.scene, q.scene_index, q.limits);
  print_warnings(scene.warnings);
  const scene::Camera& camera = scene.camera_or_first(q.camera);
  scene::Accel accel(scene);
  const request::ResolvedRequest r = request::resolve(q, scene, accel, camera);
  if (print_request) {
    std::printf("%s\n", request::resolved_json(r).dump(2).c_str());
    return 0;
  }
  if (!q.quiet) std::printf("%s", request::describe_setup(r, scene, camera).c_str());
  print_environment_notices(r.environment);
  const request::ImageResult result = request::render_image(r, scene, accel, camera);
  if (!q.quiet) std::printf("%s", request::describe(r, result).c_str());
  std::printf("wrote   %s\n", std::filesystem::absolute(q.out).lexically_normal().c_str());
  if (!q.preview_inputs.empty())
    std::printf("wrote   %s\n",
                std::filesystem::absolute(q.preview_inputs).lexically_normal().c_str());
  return 0;
}

// Every option of `render`, onto `r`.
void add_render_options(CLI::App* cmd, request::RenderRequest& r) {
  add_scene_options(cmd, r);
  cmd->add_option("-o,--out", r.out,
                  "Output image: .png (sRGB) or .exr (linear, with Z, N and id channels)")
      ->capture_default_str();
  add_size_options(cmd, r);
  cmd->add_option("--spp", r.spp,
                  "Samples (lens rays) per pixel; pinhole samples in the preview modes (default "
                  "there: 1, with 1 light sample, 2 gather rays, 1 bounce and specular depth 1 "
                  "unless shading options are given)")
      ->default_str("16")
      ->check(CLI::Range(1, 1 << 20));
  cmd->add_option_function<std::string>(
         "--mode", [&r](const std::string& name) { r.mode = request::parse_mode(name); },
         "pinhole (all in focus), drt (distributed ray tracing, the reference), "
         "accumulation (one lens point per pass), or a post-processed preview of a "
         "pinhole render: preview (layered, Kraus & Strengert), preview-occlusion "
         "(layered with the paper's occlusion fix: also renders what the pinhole "
         "cannot see), preview-gather, preview-scatter")
      ->default_str(request::mode_name(r.mode))
      ->check(CLI::IsMember(request::mode_names()));
  add_lens_options(cmd, r.lens);
  add_real_lens_options(cmd, r.lens);
  add_seed_and_threads(cmd, r, "Random seed; a fixed seed gives the same image");
  add_shading_options(cmd, r);
  add_environment_options(cmd, r.environment);
  add_adaptive_options(cmd, r);
  add_cache_options(cmd, r,
                    "Radiance cache: none (shade every lens ray), octree (the paper's) or vdb "
                    "(OpenVDB grids keyed by depth-dependent voxel size); auto: vdb for drt and "
                    "accumulation renders, none otherwise");
  cmd->add_option("--cache-debug", r.cache_debug,
                  "Write PREFIX-hits.png (fraction of lookups served) and PREFIX-density.png "
                  "(samples created per pixel)");
  cmd->add_option("--cache-trace", r.cache_trace,
                  "Record the cache's lookups and inserts to FILE for bench/cache_replay_bench");
  cmd->add_option("--stats-json", r.stats_json, "Write render statistics as JSON to this file");
  add_denoise_option(cmd, r);
  add_composite_options(cmd, r.composite, r.edge_rays);
  cmd->add_option("--save-preview-inputs", r.preview_inputs,
                  "Preview modes: also save the pinhole images (and revealed layers) as one "
                  "multi-part .exr for 'dofcache refocus'");
  cmd->add_flag("-q,--quiet", r.quiet, "Print only the output path");
}

}  // namespace

Runner add_render_command(CLI::App& app) {
  auto o = std::make_shared<RenderOptions>();
  CLI::App* cmd = app.add_subcommand(
      "render", "Render a glTF 2.0 scene (default: the built-in Cornell box) with depth of field.");
  add_render_options(cmd, o->request);
  add_request_file_options(cmd, o->file);
  return [o] {
    return run_render(
        apply_request_file(o->file, o->request, request::Kind::Image, add_render_options),
        o->file.print);
  };
}

}  // namespace dofcache::cli
