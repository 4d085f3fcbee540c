#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>

#include "commands.h"
#include "common_options.h"
#include "dofcache/cache/radiance_cache.h"
#include "dofcache/cache/trace.h"
#include "dofcache/core/error.h"
#include "dofcache/image/image_io.h"
#include "dofcache/image/metrics.h"
#include "dofcache/preview/inputs_file.h"
#include "dofcache/preview/preview_renderer.h"
#include "dofcache/render/renderer.h"
#include "dofcache/render/setup.h"
#include "dofcache/scene/accel.h"

namespace dofcache::cli {
namespace {

struct RenderOptions {
  std::string scene_path, out = "dofcache.png", camera, mode = "drt", stats_json;
  std::string save_preview_inputs;
  int scene_index = -1, width = 640, height = 0, spp = 16, threads = 0;
  scene::LoadLimits limits;
  std::uint64_t seed = 1;
  std::optional<double> fstop, focal_length, focus_distance;
  render::ShadingSettings shading;
  render::EnvironmentSettings environment;
  std::string cache = "auto", cache_debug, cache_trace;
  std::string adaptive = "auto";
  render::AdaptiveSampling adaptive_settings;
  render::CacheSettings cache_settings;
  preview::PreviewOptions composite;  // only layer_composite and edge_rays are set from flags
  bool quiet = false;
  // Whether --spp / any shading option was given: the preview modes default to quick inputs.
  bool spp_given = false, shading_given = false;
};

std::string describe_lens(const lens::ThinLens& l) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "%.0f mm f/%.3g, focus %.3g m (aperture %.3g mm)",
                l.focal_length * 1000.0, l.fstop, l.focus_distance, l.aperture_diameter() * 1000.0);
  return buf;
}

nlohmann::json shading_json(const render::ShadingSettings& s) {
  return {{"light_samples", s.light_samples}, {"gather_rays", s.gather_rays},
          {"bounces", s.bounces}, {"specular_depth", s.specular_depth},
          {"rough_lobe_rate", s.rough_lobe_rate}};
}

std::vector<std::string> with_auto(std::vector<std::string> names) {
  names.push_back("auto");
  return names;
}

// "preview" -> Layered, "preview-occlusion" -> LayeredOcclusion, ...; nullopt for the integrators.
std::optional<preview::PreviewMethod> preview_method(const std::string& mode) {
  if (mode == "preview") return preview::PreviewMethod::Layered;
  if (mode == "preview-occlusion") return preview::PreviewMethod::LayeredOcclusion;
  if (mode == "preview-gather") return preview::PreviewMethod::Gather;
  if (mode == "preview-scatter") return preview::PreviewMethod::Scatter;
  return std::nullopt;
}

// The preview modes: a pinhole render (plus, for the occlusion fix, the near-plane renders)
// post-processed into a depth-of-field image.
int run_preview(const RenderOptions& o, const scene::Scene& scene, const scene::Accel& accel,
                const scene::Camera& camera, const render::RenderSettings& s,
                const render::ResolvedEnvironment& environment, preview::PreviewMethod method) {
  preview::PreviewOptions options;
  options.threads = o.threads;
  apply_composite_options(o.composite, options);
  preview::ScenePreview p =
      preview::render_scene_preview(scene, accel, camera, s, method, options);
  image::write_image(o.out, p.image, {{{"Z"}, p.inputs.depth}, {{"id"}, p.inputs.ids}});
  if (!o.save_preview_inputs.empty())
    preview::save_preview_inputs(o.save_preview_inputs, p.inputs, p.coverage, options);
  const preview::ScenePreviewTimings& t = p.timings;
  if (!o.stats_json.empty()) {
    nlohmann::json j = {
        {"scene", scene.source}, {"camera", camera.name}, {"mode", o.mode},
        {"method", preview::preview_method_name(method)}, {"width", s.width},
        {"height", s.height}, {"spp", s.spp}, {"seed", s.seed},
        {"threads", t.pinhole_stats.threads}, {"seconds", t.total_ms * 1e-3},
        {"lens", {{"focal_length", s.lens.focal_length}, {"fstop", s.lens.fstop},
                  {"focus_distance", s.lens.focus_distance}}},
        {"environment", environment_json(o.environment, environment)},
        {"shading", shading_json(s.shading)},
        {"preview", {{"layers", t.layers}, {"revealed_layers", t.revealed_layers},
                     {"revealed_pixels", t.revealed_pixels}, {"id_pixels", t.id_pixels},
                     {"pinhole_render_ms", t.pinhole_render_ms},
                     {"id_render_ms", t.id_render_ms}, {"mask_build_ms", t.mask_build_ms},
                     {"extra_region_mask_ms", t.mask_ms()},
                     {"extra_render_ms", t.extra_render_ms},
                     {"postprocess_ms", t.postprocess_ms}, {"total_ms", t.total_ms}}},
        {"output", o.out}};
    write_json_file(o.stats_json, j);
  }
  if (!o.quiet) {
    std::printf("preview %dx%d %s, %d pinhole spp, %d layers", s.width, s.height,
                preview::preview_method_name(method), s.spp, t.layers);
    if (method == preview::PreviewMethod::LayeredOcclusion)
      std::printf(" (%d revealed, %llu px rendered again)", t.revealed_layers,
                  static_cast<unsigned long long>(t.revealed_pixels));
    std::printf(": %.2f s\n        pinhole %.1f ms, extra-region mask %.1f ms, extra render "
                "%.1f ms, post-process %.1f ms\n",
                t.total_ms * 1e-3, t.pinhole_render_ms, t.mask_ms(), t.extra_render_ms,
                t.postprocess_ms);
  }
  std::printf("wrote   %s\n", std::filesystem::absolute(o.out).lexically_normal().c_str());
  if (!o.save_preview_inputs.empty())
    std::printf("wrote   %s\n",
                std::filesystem::absolute(o.save_preview_inputs).lexically_normal().c_str());
  return 0;
}

int run_render(const RenderOptions& o) {
  scene::Scene scene = render::load_scene(o.scene_path, o.scene_index, o.limits);
  for (const std::string& w : scene.warnings) std::fprintf(stderr, "dofcache: warning: %s\n", w.c_str());
  const scene::Camera& camera = scene.camera_or_first(o.camera);
  scene::Accel accel(scene);

  render::RenderSettings s;
  s.width = o.width;
  s.height = o.height > 0 ? o.height : render::height_for_width(camera, o.width);
  s.spp = o.spp;
  const std::optional<preview::PreviewMethod> method = preview_method(o.mode);
  s.mode = method ? render::Mode::Pinhole : render::parse_mode(o.mode);
  s.seed = o.seed;
  s.threads = o.threads;
  s.shading = o.shading;
  // A preview is a quick look: its inputs default to one sample with cut-down shading (the
  // post-process blurs most of their noise); --spp and the shading options ask for better ones.
  if (method && !o.spp_given) s.spp = preview::kQuickInputSpp;
  if (method && !o.shading_given) s.shading = preview::quick_input_shading(o.shading, true);
  const render::ResolvedEnvironment environment =
      render::resolve_environment(o.environment, scene, o.limits);
  s.shading.environment = environment.environment;
  render::ResolvedLens lens = render::resolve_lens(scene, accel, camera,
                                                   {o.focal_length, o.fstop, o.focus_distance});
  s.lens = lens.lens;
  s.progress = o.quiet ? Progress::Display::Never : Progress::Display::Auto;
  // auto: the vdb cache where it applies (drt, accumulation), which the peer benchmark measured
  // at least as fast as the best uncached shading at equal error (docs/peer.md); none for the
  // pinhole and preview modes, which shade each pixel once.
  const bool integrates_lens = o.mode == "drt" || o.mode == "accumulation";
  const std::string backend = o.cache != "auto" ? o.cache : integrates_lens ? "vdb" : "none";
  std::unique_ptr<cache::RadianceCache> radiance_cache = cache::make_radiance_cache(backend);
  std::unique_ptr<cache::TraceWriter> trace;
  s.cache = o.cache_settings;
  s.cache.cache = radiance_cache.get();
  // auto: on for drt, whose remaining noise (the lens) gathers where out-of-focus edges blur.
  s.adaptive = o.adaptive_settings;
  s.adaptive.enabled = o.adaptive == "on" || (o.adaptive == "auto" && o.mode == "drt");

  if (!o.quiet) {
    std::printf("scene   %s: %zu triangles, %zu emissive, %zu punctual lights\n",
                scene.source.c_str(), scene.mesh.triangles.size(), scene.emitters.size(),
                scene.lights.size());
    if (environment.environment)
      std::printf("env     %s\n", environment.description.c_str());
    if (camera.synthesized)
      std::printf("notice  the scene has no camera; using one that frames its bounds\n");
    std::printf("camera  '%s', lens %s%s\n", camera.name.c_str(), describe_lens(s.lens).c_str(),
                lens.focus_from_scene ? " (autofocus on the image centre)" : "");
  }
  // Validate everything (including the output format) before spending time on the render.
  if (method && radiance_cache)
    throw dofcache::Error("the preview modes render pinhole images and use no radiance cache "
                          "(drop --cache)");
  s.validate();
  image::check_output_path(o.out);
  if (!o.save_preview_inputs.empty()) {
    if (!method)
      throw dofcache::Error("--save-preview-inputs needs a preview mode (--mode preview, "
                            "preview-occlusion, preview-gather or preview-scatter)");
    std::string ext = std::filesystem::path(o.save_preview_inputs).extension().string();
    if (ext != ".exr" && ext != ".EXR")
      throw dofcache::Error("preview inputs are saved as .exr, not '" + o.save_preview_inputs +
                            "'");
    image::check_output_path(o.save_preview_inputs);
  }
  print_environment_notices(environment);
  if (method) return run_preview(o, scene, accel, camera, s, environment, *method);
  if (!o.cache_debug.empty()) image::check_output_path(o.cache_debug + "-hits.png");
  if (!o.cache_trace.empty()) {
    if (!radiance_cache) throw dofcache::Error("--cache-trace needs a cache (--cache octree or vdb)");
    trace = std::make_unique<cache::TraceWriter>(o.cache_trace, s.cache.lookup);
    s.cache.trace = trace.get();
  }
  render::RenderOutput out = render::render(scene, accel, camera, s);

  image::write_image(o.out, out.color,
                     {{{"Z"}, out.depth}, {{"N.X", "N.Y", "N.Z"}, out.normal}, {{"id"}, out.ids}});
  if (trace) trace->close();
  if (!o.cache_debug.empty() && radiance_cache) {
    double max_density = 1.0;
    for (float v : out.cache_density.data()) max_density = std::max<double>(max_density, v);
    image::write_image(o.cache_debug + "-hits.png", image::false_color(out.cache_hits, 1.0));
    image::write_image(o.cache_debug + "-density.png",
                       image::false_color(out.cache_density, max_density));
  }
  const render::RenderStats& st = out.stats;
  if (!o.stats_json.empty()) {
    nlohmann::json j = {
        {"scene", scene.source}, {"camera", camera.name}, {"mode", render::mode_name(s.mode)},
        {"width", s.width}, {"height", s.height}, {"spp", s.spp}, {"seed", s.seed},
        {"adaptive", s.adaptive.enabled &&
                         render::pilot_samples(s.adaptive, s.spp) > 0},
        {"threads", st.threads}, {"seconds", st.seconds}, {"camera_rays", st.camera_rays},
        {"rays", st.rays}, {"rays_per_second", st.rays_per_second()},
        {"shading_points", st.shading_points},
        {"lens", {{"focal_length", s.lens.focal_length}, {"fstop", s.lens.fstop},
                  {"focus_distance", s.lens.focus_distance}}},
        {"shading", shading_json(s.shading)},
        {"environment", environment_json(o.environment, environment)},
        {"output", o.out},
        {"cache", cache_settings_json(backend, s)}};
    j["cache"].update({{"lookups", st.cache_lookups}, {"hits", st.cache_hits},
                       {"tile_hits", st.cache_tile_hits}, {"hit_rate", st.cache_hit_rate()},
                       {"direct", st.cache_direct},
                       {"inserted", st.cache_inserted}, {"samples", st.cache_samples},
                       {"memory_bytes", st.cache_memory_bytes},
                       {"lookup_seconds", st.cache_lookup_seconds},
                       {"insert_seconds", st.cache_insert_seconds}, {"passes", st.passes}});
    write_json_file(o.stats_json, j);
  }
  if (!o.quiet)
    std::printf("render  %dx%d %s, %d spp, %d threads: %.2f s, %.2f M rays/s (%.1f M rays)\n",
                s.width, s.height, render::mode_name(s.mode), s.spp, st.threads, st.seconds,
                st.rays_per_second() * 1e-6, st.rays * 1e-6);
  if (!o.quiet && radiance_cache)
    std::printf("cache   %s: %.1f%% of %llu lookups served (%.1f%% from earlier passes), "
                "%llu samples, %.2f MB, lookup %.2f s, insert %.3f s (thread-seconds); "
                "%llu hits shaded per ray\n",
                backend.c_str(), 100.0 * st.cache_hit_rate(),
                static_cast<unsigned long long>(st.cache_lookups),
                st.cache_lookups ? 100.0 * st.cache_hits / st.cache_lookups : 0.0,
                static_cast<unsigned long long>(st.cache_samples), st.cache_memory_bytes / 1e6,
                st.cache_lookup_seconds, st.cache_insert_seconds,
                static_cast<unsigned long long>(st.cache_direct));
  std::printf("wrote   %s\n", std::filesystem::absolute(o.out).lexically_normal().c_str());
  return 0;
}

}  // namespace

Runner add_render_command(CLI::App& app) {
  auto o = std::make_shared<RenderOptions>();
  CLI::App* cmd = app.add_subcommand(
      "render", "Render a glTF 2.0 scene (default: the built-in Cornell box) with depth of field.");
  add_scene_options(cmd, o->scene_path, o->camera, o->scene_index, o->limits);
  cmd->add_option("-o,--out", o->out,
                  "Output image: .png (sRGB) or .exr (linear, with Z, N and id channels)")
      ->capture_default_str();
  add_size_options(cmd, o->width, o->height);
  cmd->add_option("--spp", o->spp,
                  "Samples (lens rays) per pixel; pinhole samples in the preview modes (default "
                  "there: 1, with 1 light sample, 2 gather rays, 1 bounce and specular depth 1 "
                  "unless shading options are given)")
      ->capture_default_str()
      ->check(CLI::Range(1, 1 << 20));
  cmd->add_option("--mode", o->mode,
                  "pinhole (all in focus), drt (distributed ray tracing, the reference), "
                  "accumulation (one lens point per pass), or a post-processed preview of a "
                  "pinhole render: preview (layered, Kraus & Strengert), preview-occlusion "
                  "(layered with the paper's occlusion fix: also renders what the pinhole "
                  "cannot see), preview-gather, preview-scatter")
      ->capture_default_str()
      ->check(CLI::IsMember({"pinhole", "drt", "accumulation", "preview", "preview-occlusion",
                             "preview-gather", "preview-scatter"}));
  add_lens_options(cmd, o->fstop, o->focal_length, o->focus_distance);
  add_seed_and_threads(cmd, o->seed, o->threads,
                       "Random seed; a fixed seed gives the same image");
  add_shading_options(cmd, o->shading);
  add_environment_options(cmd, o->environment);
  cmd->add_option("--adaptive", o->adaptive,
                  "Adaptive lens sampling (drt): a pilot of --adaptive-pilot of the samples "
                  "measures each pixel's noise, the rest go where it is; --spp is then the mean "
                  "per pixel. auto: on for drt")
      ->capture_default_str()
      ->check(CLI::IsMember({"auto", "on", "off"}));
  cmd->add_option("--adaptive-pilot", o->adaptive_settings.pilot_fraction,
                  "Adaptive sampling: the pilot's fraction of the samples (rounded down to a "
                  "power of two, at least 8 per pixel, or half the samples below 16 spp; below 4 spp "
                  "sampling stays uniform)")
      ->capture_default_str()->check(CLI::Range(1e-3, 1.0));
  cmd->add_option("--adaptive-min", o->adaptive_settings.min_factor,
                  "Adaptive sampling: every pixel takes at least this fraction of --spp")
      ->capture_default_str()->check(CLI::Range(0.0, 1.0));
  cmd->add_option("--adaptive-max", o->adaptive_settings.max_factor,
                  "Adaptive sampling: no pixel takes more than this many times --spp")
      ->capture_default_str()->check(CLI::Range(1.0, 1024.0));
  cmd->add_option("--cache", o->cache,
                  "Radiance cache: none (shade every lens ray), octree (the paper's) or vdb "
                  "(OpenVDB grids keyed by depth-dependent voxel size); auto: vdb for drt and "
                  "accumulation renders, none otherwise")
      ->capture_default_str()
      ->check(CLI::IsMember(with_auto(cache::radiance_cache_backends())));
  // A single image chooses the cache sample quality from its lens samples by default (measured
  // best at equal quality); sequences keep a fixed default, since cache files record it.
  o->cache_settings.sample_quality = render::kAutoSampleQuality;
  o->cache_settings.radius.min_factor = cache::kSingleImageMinFactor;
  o->cache_settings.direct_below = render::kSingleImageDirectBelow;
  add_cache_tuning_options(cmd, o->cache_settings);
  cmd->add_option("--cache-debug", o->cache_debug,
                  "Write PREFIX-hits.png (fraction of lookups served) and PREFIX-density.png "
                  "(samples created per pixel)");
  cmd->add_option("--cache-trace", o->cache_trace,
                  "Record the cache's lookups and inserts to FILE for bench/cache_replay_bench");
  cmd->add_option("--stats-json", o->stats_json, "Write render statistics as JSON to this file");
  add_composite_options(cmd, o->composite);
  cmd->add_option("--save-preview-inputs", o->save_preview_inputs,
                  "Preview modes: also save the pinhole images (and revealed layers) as one "
                  "multi-part .exr for 'dofcache refocus'");
  cmd->add_flag("-q,--quiet", o->quiet, "Print only the output path");
  return [o, cmd] {
    o->spp_given = cmd->count("--spp") > 0;
    for (const char* name :
         {"--light-samples", "--gather-rays", "--bounces", "--specular-depth", "--rough-lobe-rate"})
      o->shading_given = o->shading_given || cmd->count(name) > 0;
    return run_render(*o);
  };
}

}  // namespace dofcache::cli
