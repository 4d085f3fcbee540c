#include "common_options.h"

#include <cstdio>

namespace dofcache::cli {

void add_scene_options(CLI::App* cmd, std::string& scene_path, std::string& camera,
                       int& scene_index, scene::LoadLimits& limits) {
  cmd->add_option("SCENE", scene_path, ".gltf or .glb file; omit for the built-in scene");
  cmd->add_option("--camera", camera, "Camera name (default: the scene's first camera)");
  cmd->add_option("--scene-index", scene_index, "glTF scene to load (default: the file's default)");
  // Limits on what a scene file may make the loader allocate (docs/reliability.md).
  cmd->add_option("--max-vertices", limits.max_vertices,
                  "Refuse a scene with more vertices (all mesh instances)")
      ->capture_default_str()->check(CLI::PositiveNumber);
  cmd->add_option("--max-triangles", limits.max_triangles,
                  "Refuse a scene with more triangles (all mesh instances)")
      ->capture_default_str()->check(CLI::PositiveNumber);
  cmd->add_option("--max-texture-pixels", limits.max_texture_pixels,
                  "Refuse a scene whose images have more pixels in all")
      ->capture_default_str()->check(CLI::PositiveNumber);
  cmd->add_option("--max-node-depth", limits.max_node_depth,
                  "Refuse a scene whose node hierarchy is deeper")
      ->capture_default_str()->check(CLI::Range(1, 100000));
}

void add_size_options(CLI::App* cmd, int& width, int& height) {
  cmd->add_option("--width", width, "Image width in pixels")->capture_default_str()
      ->check(CLI::Range(1, 16384));
  cmd->add_option("--height", height, "Image height (default: from the camera's aspect ratio)")
      ->check(CLI::Range(1, 16384));
}

void add_lens_options(CLI::App* cmd, std::optional<double>& fstop,
                      std::optional<double>& focal_length, std::optional<double>& focus_distance,
                      const std::string& unset) {
  const std::string note = unset.empty() ? "" : " (default: " + unset + ")";
  cmd->add_option("--fstop", fstop, "f-number n (aperture diameter = focal length / n)" + note);
  cmd->add_option("--focal-length", focal_length, "Focal length in metres (e.g. 0.05)" + note);
  cmd->add_option("--focus-distance", focus_distance, "Distance in focus, metres" + note);
}

void add_seed_and_threads(CLI::App* cmd, std::uint64_t& seed, int& threads,
                          const std::string& seed_help) {
  cmd->add_option("--seed", seed, seed_help)->capture_default_str();
  cmd->add_option("--threads", threads, "Worker threads (0: all cores)")->capture_default_str()
      ->check(CLI::Range(0, 4096));
}

void add_shading_options(CLI::App* cmd, render::ShadingSettings& shading) {
  cmd->add_option("--light-samples", shading.light_samples,
                  "Light samples (shadow rays) per camera hit, combined with the gather rays by "
                  "multiple importance sampling")
      ->capture_default_str()->check(CLI::Range(0, 4096));
  cmd->add_option("--gather-rays", shading.gather_rays,
                  "Cosine-weighted rays per camera hit: indirect light, and direct light where "
                  "they meet an emitter (1 with 1 light sample is a plain path tracer)")
      ->capture_default_str()->check(CLI::Range(0, 65536));
  cmd->add_option("--bounces", shading.bounces,
                  "Indirect bounces, diffuse or glossy, as Blender Cycles' max bounces (0: direct "
                  "light only)")
      ->capture_default_str()->check(CLI::Range(0, 16));
  cmd->add_option("--specular-depth", shading.specular_depth,
                  "Maximum chain of glossy/mirror reflections (0: no specular lobe)")
      ->capture_default_str()->check(CLI::Range(0, 16));
  cmd->add_option("--rough-lobe-rate", shading.rough_lobe_rate,
                  "At a camera hit, a rough dielectric's specular lobe (a few percent of the "
                  "light) is evaluated on this many times its share of the lens rays, weighted "
                  "by the inverse (unbiased; 0: on every ray)")
      ->capture_default_str()->check(CLI::Range(0.0, 1e3));
}

void add_cache_tuning_options(CLI::App* cmd, render::CacheSettings& cache) {
  cmd->add_option("--min-factor", cache.radius.min_factor,
                  "Cache sample radius in focus, in pixel footprints (Algorithm 1's minFactor)")
      ->capture_default_str()->check(CLI::Range(1e-3, 1e4));
  cmd->add_option_function<std::string>(
         "--cache-radius",
         [&cache](const std::string& name) { cache.radius.rule = cache::parse_radius_rule(name); },
         "How far a cache sample is reused: paper (eqs. 4.1-4.2: CoC out of focus, half "
                  "a pixel in focus) or adaptive (also widened where the illumination is smooth, "
                  "from the distances its gather rays measured)")
      ->default_str(cache::radius_rule_name(cache.radius.rule))
      ->check(CLI::IsMember({"paper", "adaptive"}));
  cmd->add_option("--cache-accuracy", cache.radius.accuracy,
                  "Adaptive radius: fraction of the harmonic mean distance to nearby geometry")
      ->capture_default_str()->check(CLI::Range(1e-3, 10.0));
  cmd->add_option("--cache-max-radius", cache.radius.max_radius_pixels,
                  "Adaptive radius: cap in pixel footprints")
      ->capture_default_str()->check(CLI::Range(0.0, 1e4));
  cmd->add_option("--cache-normal-angle", cache.lookup.max_normal_angle_deg,
                  "Cache lookups reject samples whose normal differs by more (degrees)")
      ->capture_default_str()->check(CLI::Range(0.1, 90.0));
  cmd->add_option("--cache-min-samples", cache.lookup.min_samples,
                  "Samples a cache lookup must accept to succeed")
      ->capture_default_str()->check(CLI::Range(1, 1024));
  cmd->add_option("--cache-sample-quality", cache.sample_quality,
                  "A cache sample uses this many times the light and gather samples of a "
                  "per-ray shade (it is reused by many lens rays); 0: chosen from --spp, "
                  "round(spp / 32) for the default --gather-rays, at least 1 (docs/cache.md)")
      ->capture_default_str()->check(CLI::Range(0, 256));
  cmd->add_option("--cache-direct-below", cache.direct_below,
                  "Hits a new cache sample would serve to fewer lens rays than this (spp times "
                  "its area in pixels: in focus at few samples) are shaded per ray instead; "
                  "0: cache every hit (docs/cache.md)")
      ->capture_default_str()->check(CLI::Range(0.0, 1e6));
  cmd->add_option("--cache-direct-gather-rays", cache.direct_gather_rays,
                  "Gather rays of a hit shaded per ray in a cached render")
      ->capture_default_str()->check(CLI::Range(0, 4096));
  cmd->add_option("--cache-direct-light-samples", cache.direct_light_samples,
                  "Light samples of a hit shaded per ray in a cached render")
      ->capture_default_str()->check(CLI::Range(0, 4096));
  cmd->add_option("--cache-sample-rounds", cache.max_sample_rounds,
                  "A cache sample whose gather rays disagree (their mean's standard error above "
                  "--cache-sample-error of its value) takes them again, in doubling rounds up "
                  "to this many (1: never)")
      ->capture_default_str()->check(CLI::Range(1, 64));
  cmd->add_option("--cache-sample-error", cache.sample_error,
                  "Relative standard error a cache sample's gather rays must reach")
      ->capture_default_str()->check(CLI::Range(1e-3, 10.0));
}

void add_environment_options(CLI::App* cmd, render::EnvironmentSettings& environment) {
  cmd->add_option("--env", environment.path,
                  "Environment light: a lat-long (equirectangular, 2:1) .exr or .hdr map, top "
                  "row the zenith (+Y), centre towards -Z; importance-sampled and combined with "
                  "BSDF sampling by MIS (docs/design.md)");
  cmd->add_option_function<std::vector<float>>(
         "--env-color",
         [&environment](const std::vector<float>& c) {
           environment.color = glm::vec3(c[0], c[1], c[2]);
         },
         "A constant environment of this linear RGB radiance, e.g. 1,1,1 (0,0,0: none, which "
         "also keeps a scene without lights dark)")
      ->expected(3)
      ->delimiter(',');
  cmd->add_option("--env-strength", environment.strength,
                  "Multiplies the environment's radiance (--env, --env-color, the default sky)")
      ->capture_default_str()->check(CLI::Range(0.0, 1e6));
  cmd->add_option("--env-rotation", environment.rotation_degrees,
                  "Turns the environment map about the vertical axis (+Y), degrees; positive "
                  "turns +X towards -Z")
      ->capture_default_str()->check(CLI::Range(-1e6, 1e6));
  cmd->add_option_function<std::string>(
         "--env-visible",
         [&environment](const std::string& v) { environment.visible = v == "on"; },
         "on: camera rays that miss the scene see the environment (the background); off: "
         "they see black, the environment still lights the scene")
      ->check(CLI::IsMember({"on", "off"}))
      ->default_str("on");
  cmd->add_flag_callback(
      "--no-default-sky", [&environment] { environment.default_sky = false; },
      "A scene with no light of any kind (no emissive surface, no KHR_lights_punctual light, no "
      "--env) is lit by a default sky, as glTF viewers do; this keeps it black instead");
}

void print_environment_notices(const render::ResolvedEnvironment& r) {
  for (const std::string& w : r.warnings)
    std::fprintf(stderr, "dofcache: warning: %s\n", w.c_str());
  if (r.default_sky)
    std::fprintf(stderr,
                 "dofcache: notice: the scene has no light; it is lit by a default sky (choose "
                 "one with --env FILE or --env-color R,G,B, or none with --no-default-sky)\n");
}

nlohmann::json environment_json(const render::EnvironmentSettings& settings,
                                const render::ResolvedEnvironment& environment) {
  const render::Environment* e = environment.environment.get();
  const char* kind = !e                       ? "none"
                     : environment.default_sky ? "default_sky"
                     : e->is_constant()        ? "constant"
                                               : "map";
  nlohmann::json j = {{"kind", kind}, {"description", environment.description}};
  if (e) {
    const glm::vec3 m = e->mean_radiance();
    j.update({{"strength", settings.strength},
              {"rotation_deg", e->rotation() * 57.29577951f},
              {"visible", e->visible()},
              {"mean_radiance", {m.x, m.y, m.z}}});
    if (!settings.path.empty()) j["path"] = settings.path;
  }
  return j;
}

nlohmann::json cache_settings_json(const std::string& backend,
                                   const render::RenderSettings& settings) {
  const render::CacheSettings& cache = settings.cache;
  return {{"backend", backend},
          {"radius_rule", cache::radius_rule_name(cache.radius.rule)},
          {"min_factor", cache.radius.min_factor},
          {"accuracy", cache.radius.accuracy},
          {"max_radius_pixels", cache.radius.max_radius_pixels},
          {"sample_quality", render::effective_sample_quality(settings)},
          {"sample_error", cache.sample_error},
          {"max_sample_rounds", cache.max_sample_rounds},
          {"direct_below", cache.direct_below},
          {"direct_light_samples", cache.direct_light_samples},
          {"direct_gather_rays", cache.direct_gather_rays},
          {"max_normal_angle_deg", cache.lookup.max_normal_angle_deg},
          {"min_samples", cache.lookup.min_samples}};
}

void add_composite_options(CLI::App* cmd, preview::PreviewOptions& options) {
  cmd->add_option_function<std::string>(
         "--layer-composite",
         [&options](const std::string& name) {
           options.layer_composite = name == "slabs" ? preview::LayerComposite::Slabs
                                                     : preview::LayerComposite::Over;
         },
         "Layered previews: how blurred layers are composited. over: Kraus & Strengert's "
         "trapezoid mattes composited with 'over'; slabs: each layer's hat split at its anchor "
         "and the halves sharing a slab added, so defocused silhouettes cover like the lens "
         "(2-3x less error at silhouettes; a curved surface can show a faint seam)")
      ->check(CLI::IsMember({"over", "slabs"}))
      ->default_str("over");
  cmd->add_option("--edge-rays", options.edge_rays,
                  "preview-occlusion: lens rays per pixel traced through the pinhole surface and "
                  "the revealed layers near occluding edges, where layers cannot tell which part "
                  "of the lens sees past an edge (rounded to a square grid; 0, or fewer than 4: "
                  "layers only, faster, more edge error)")
      ->capture_default_str()
      ->check(CLI::Range(0, 1024));
}

void apply_composite_options(const preview::PreviewOptions& flags,
                             preview::PreviewOptions& options) {
  options.layer_composite = flags.layer_composite;
  options.edge_rays = flags.edge_rays;
}

}  // namespace dofcache::cli
