#include "common_options.h"

#include <algorithm>
#include <cstdio>
#include <functional>
#include <sstream>

#include "dofcache/cache/radiance_cache.h"
#include "dofcache/cache/sample_radius.h"
#include "dofcache/core/error.h"
#include "dofcache/lens/shipped_lenses.h"

namespace dofcache::cli {
namespace {

std::vector<std::string> g_command_arguments;

template <class T>
std::string text(const T& v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// A shading option: sets one field of the request's shading, starting it from the renderer's
// defaults when it is the first one given.
template <class T>
void shading_option(CLI::App* cmd, request::RenderRequest& r, const char* name,
                    T render::ShadingSettings::*field, const std::string& help,
                    const CLI::Validator& check) {
  cmd->add_option_function<T>(
         name,
         [&r, field](const T& v) {
           if (!r.shading) r.shading = render::ShadingSettings{};
           (*r.shading).*field = v;
         },
         help)
      ->default_str(text(render::ShadingSettings{}.*field))
      ->check(check);
}

// An auto|on|off option onto `field`.
void choice_option(CLI::App* cmd, const char* name, request::Choice& field,
                   const std::string& help) {
  cmd->add_option_function<std::string>(
         name, [&field](const std::string& v) { field = request::parse_choice(v); }, help)
      ->default_str(request::choice_name(field))
      ->check(CLI::IsMember(request::choice_names()));
}

}  // namespace

void set_command_arguments(std::vector<std::string> args) { g_command_arguments = std::move(args); }

void add_scene_options(CLI::App* cmd, request::RenderRequest& r) {
  scene::LoadLimits& limits = r.limits;
  cmd->add_option("SCENE", r.scene, ".gltf or .glb file; omit for the built-in scene");
  cmd->add_option("--camera", r.camera, "Camera name (default: the scene's first camera)");
  cmd->add_option("--scene-index", r.scene_index, "glTF scene to load (default: the file's default)");
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

void add_size_options(CLI::App* cmd, request::RenderRequest& r) {
  cmd->add_option("--width", r.width, "Image width in pixels")->capture_default_str()
      ->check(CLI::Range(1, 16384));
  cmd->add_option("--height", r.height, "Image height (default: from the camera's aspect ratio)")
      ->check(CLI::Range(1, 16384));
}

namespace {

// An option taking two numbers, "A,B" (or "A B"), handed to `set`.
void add_pair_option(CLI::App* cmd, const char* name,
                     std::function<void(double, double)> set, const std::string& help) {
  cmd->add_option_function<std::vector<double>>(
         name, [set](const std::vector<double>& v) { set(v[0], v[1]); }, help)
      ->expected(2)
      ->delimiter(',');
}

}  // namespace

void add_lens_options(CLI::App* cmd, render::LensOverrides& lens, const std::string& unset) {
  const std::string note = unset.empty() ? "" : " (default: " + unset + ")";
  cmd->add_option("--fstop", lens.fstop, "f-number n (aperture diameter = focal length / n)" + note);
  cmd->add_option("--focal-length", lens.focal_length, "Focal length in metres (e.g. 0.05)" + note);
  cmd->add_option("--focus-distance", lens.focus_distance, "Distance in focus, metres" + note);
  // The aperture's shape (docs/lens.md); 1-2 blades and the like are refused by the lens's check.
  lens::ApertureChoices& a = lens.aperture;
  cmd->add_option("--aperture-blades", a.blades,
                  "Aperture blades: 0 round, 3-16 a polygon (polygonal highlights)" + note);
  cmd->add_option("--aperture-rotation", a.rotation_deg,
                  "Angle of a corner of a highlight behind the focus from the image's +x axis, "
                  "degrees counter-clockwise" + note);
  cmd->add_option("--aperture-roundness", a.roundness,
                  "Blade curvature: 0 straight blades, 1 round" + note);
  cmd->add_option("--anamorphic-ratio", a.anamorphic_ratio,
                  "The bokeh's height over its width (2: tall ovals, as anamorphic lenses give)" +
                      note);
  add_pair_option(
      cmd, "--vignetting-stop",
      [&a](double r, double d) { a.vignetting_stop = lens::VignettingStop{r, d}; },
      "R,D: a second circular stop of radius R at D metres in front of the aperture, which clips "
      "off-axis lens rays (cat's-eye bokeh towards the corners, optical vignetting)" + note);
  cmd->add_option("--axial-ca", a.axial_ca,
                  "Axial chromatic aberration: metres between the red and blue planes of focus "
                  "(red farther), coloured fringes on defocused edges" + note);
  cmd->add_option("--lateral-ca", a.lateral_ca,
                  "Lateral chromatic aberration: red's magnification over blue's, minus 1 (0.01: "
                  "red 1 % larger), fringes towards the frame's edges" + note);
  cmd->add_option_function<std::string>(
         "--aperture-profile",
         [&a](const std::string& name) { a.profile = lens::parse_aperture_profile(name); },
         "Transmission across the aperture: uniform, centre (soft bokeh) or rim (bright-rimmed "
         "\"soap bubble\" bokeh); it multiplies the shape" + note)
      ->check(CLI::IsMember({"uniform", "centre", "center", "rim"}));
  add_pair_option(
      cmd, "--lens-tilt", [&a](double x, double y) { a.lens_tilt = std::pair{x, y}; },
      "X,Y degrees: tilt the lens about the horizontal axis (positive: the plane of focus reaches "
      "down, as onto a floor) and the vertical one (positive: towards the left); the plane of "
      "focus follows the Scheimpflug rule" + note);
  add_pair_option(
      cmd, "--lens-shift", [&a](double x, double y) { a.lens_shift = std::pair{x, y}; },
      "X,Y: shift the film right and up by this many image heights (verticals stay parallel)" +
          note);
  cmd->add_option_function<std::string>(
      "--aperture-image", [&a](const std::string& file) { a.image = file; },
      "A grey-scale PNG or EXR: the transmission over the aperture (the square around the round "
      "one, top row up), importance-sampled; it replaces blades and roundness" + note);
  cmd->add_option("--aperture-profile-strength", a.profile_strength,
                  "How strongly the profile weighs: 0 none, 1 full (transmission 0 at the rim or "
                  "the centre); default 1" + note);
}

void add_real_lens_options(CLI::App* cmd, render::LensOverrides& lens) {
  cmd->add_option("--lens-file", lens.real.file,
                  "A real lens: its prescription table (millimetres, front element first, as "
                  "pbrt-v4's), or a shipped lens's name (" + lens::shipped_lens_names() +
                  ": scenes/lenses/), "
                  "traced element by element. The lens and "
                  "the sensor then set the field of view (the camera's yfov and --focal-length are "
                  "ignored), --focus-distance is measured from the sensor and focuses by tracing, "
                  "--fstop sets its stop (default: the table's)");
  add_pair_option(
      cmd, "--sensor-size",
      [&lens](double w, double h) {
        lens.real.sensor.width = w;
        lens.real.sensor.height = h;
      },
      "W,H metres: the sensor behind a --lens-file (default 0.036,0.024, full frame)");
  cmd->add_option_function<std::string>(
         "--sensor-fit",
         [&lens](const std::string& name) { lens.real.sensor.fit = lens::parse_sensor_fit(name); },
         "Which part of the sensor the image covers: inside (default: the largest rectangle of "
         "the image's aspect), horizontal (the sensor's width) or vertical (its height)")
      ->check(CLI::IsMember({"inside", "horizontal", "vertical"}));
  cmd->add_flag("--exposure-follows-lens", lens.real.exposure_follows_lens,
                "With --lens-file: the image darkens with the f-stop and the lens's vignetting, as "
                "a camera's does (default: every film point sees a uniform scene at its radiance)");
}

void add_seed_and_threads(CLI::App* cmd, request::RenderRequest& r, const std::string& seed_help) {
  cmd->add_option("--seed", r.seed, seed_help)->capture_default_str();
  cmd->add_option("--pattern-seed", r.pattern_seed,
                  "Seed of the pixels' film and lens sample patterns (default: --seed; a "
                  "sequence's frames all use its --seed, so lens noise does not flicker)");
  cmd->add_option("--threads", r.threads,
                  r.core_policy == CorePolicy::LeaveOneCore
                      ? "Worker threads (0: every core this process may use but one)"
                      : "Worker threads (0: every core this process may use)")
      ->capture_default_str()
      ->check(CLI::Range(0, 4096));
}

void add_shading_options(CLI::App* cmd, request::RenderRequest& r) {
  using S = render::ShadingSettings;
  shading_option(cmd, r, "--light-samples", &S::light_samples,
                 "Light samples (shadow rays) per camera hit, combined with the gather rays by "
                 "multiple importance sampling",
                 CLI::Range(0, 4096));
  shading_option(cmd, r, "--gather-rays", &S::gather_rays,
                 "Cosine-weighted rays per camera hit: indirect light, and direct light where "
                 "they meet an emitter (1 with 1 light sample is a plain path tracer)",
                 CLI::Range(0, 65536));
  shading_option(cmd, r, "--bounces", &S::bounces,
                 "Indirect bounces, diffuse or glossy, as Blender Cycles' max bounces (0: direct "
                 "light only)",
                 CLI::Range(0, 16));
  shading_option(cmd, r, "--specular-depth", &S::specular_depth,
                 "Maximum chain of glossy/mirror reflections (0: no specular lobe)",
                 CLI::Range(0, 16));
  shading_option(cmd, r, "--rough-lobe-rate", &S::rough_lobe_rate,
                 "At a camera hit, a rough dielectric's specular lobe (a few percent of the "
                 "light) is evaluated on this many times its share of the lens rays, weighted "
                 "by the inverse (unbiased; 0: on every ray)",
                 CLI::Range(0.0, 1e3));
  cmd->add_option_function<std::string>(
         "--material-override",
         [&r](const std::string& name) {
           if (!r.shading) r.shading = render::ShadingSettings{};
           r.shading->material_override = render::parse_material_override(name);
         },
         "lambert: every material a pure Lambertian reflector of its base colour (metallic, "
         "the specular lobe and its Fresnel weight ignored; emission, normal textures and alpha "
         "kept), the physics of Cycles' Diffuse BSDF for the peer benchmark's same-physics "
         "check (docs/peer.md)")
      ->default_str(render::material_override_name(render::MaterialOverride::None))
      ->check(CLI::IsMember(render::material_override_names()));
}

void add_cache_options(CLI::App* cmd, request::RenderRequest& r, const std::string& cache_help) {
  std::vector<std::string> backends = cache::radiance_cache_backends();
  backends.push_back("auto");
  cmd->add_option("--cache", r.cache, cache_help)->capture_default_str()
      ->check(CLI::IsMember(backends));
  render::CacheSettings& cache = r.cache_settings;
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
      ->check(CLI::IsMember({cache::radius_rule_name(cache::RadiusRule::Paper),
                             cache::radius_rule_name(cache::RadiusRule::Adaptive)}));
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
                  "round(spp / 16) for the default --gather-rays, at least 1 (docs/cache.md)")
      ->capture_default_str()->check(CLI::Range(0, 256));
  cmd->add_option("--cache-direct-below", cache.direct_below,
                  "Hits a new cache sample would serve to fewer lens rays than this (spp times "
                  "its area in pixels: in focus at few samples) are shaded per ray instead; "
                  "0: cache every hit (docs/cache.md)")
      ->capture_default_str()->check(CLI::Range(0.0, 1e6));
  cmd->add_option("--cache-direct-cost-ratio", cache.direct_cost_ratio,
                  "Over the first 2 lens samples a render measures what an in-focus cache "
                  "lookup will cost (one tile row in 16 caches, the others shade per ray); above "
                  "this times a per-ray shade's rays it shades in-focus hits per ray from then "
                  "on; 0: cache them (docs/cache.md)")
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

void add_denoise_option(CLI::App* cmd, request::RenderRequest& r) {
  choice_option(cmd, "--denoise", r.denoise,
                "Denoise (edge-avoiding a-trous filters, docs/denoise.md). Preview modes and the "
                "viewer: the pinhole colour before the post-process, guided by its noise-free "
                "features. drt, accumulation, pinhole: the render, guided by its first hits "
                "averaged over the lens samples, its circles of confusion and its measured noise; "
                "a PNG gets the denoised colour, an EXR keeps the raw beauty with denoised.RGB and "
                "the guides as layers. auto: on for the preview modes, the viewer and PNG images, off "
                "for EXR images");
}

void add_adaptive_options(CLI::App* cmd, request::RenderRequest& r) {
  choice_option(cmd, "--adaptive", r.adaptive,
                "Adaptive lens sampling (drt): a pilot of --adaptive-pilot of the samples "
                "measures each pixel's noise, the rest go where it is; --spp is then the mean per "
                "pixel. auto: on for drt");
  render::AdaptiveSampling& a = r.adaptive_settings;
  cmd->add_option("--adaptive-pilot", a.pilot_fraction,
                  "Adaptive sampling: the pilot's fraction of the samples (rounded down to a "
                  "power of two, at least 8 per pixel, or half the samples below 16 spp; below 4 "
                  "spp sampling stays uniform)")
      ->capture_default_str()->check(CLI::Range(1e-3, 1.0));
  cmd->add_option("--adaptive-min", a.min_factor,
                  "Adaptive sampling: every pixel takes at least this fraction of --spp")
      ->capture_default_str()->check(CLI::Range(0.0, 1.0));
  cmd->add_option("--adaptive-max", a.max_factor,
                  "Adaptive sampling: no pixel takes more than this many times --spp")
      ->capture_default_str()->check(CLI::Range(1.0, 1024.0));
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

void add_composite_options(CLI::App* cmd, preview::LayerComposite& composite, int& edge_rays) {
  cmd->add_option_function<std::string>(
         "--layer-composite",
         [&composite](const std::string& name) {
           composite = preview::parse_layer_composite(name);
         },
         "Layered previews: how blurred layers are composited. over: Kraus & Strengert's "
         "trapezoid mattes composited with 'over'; slabs: each layer's hat split at its anchor "
         "and the halves sharing a slab added, so defocused silhouettes cover like the lens "
         "(2-3x less error at silhouettes; a curved surface can show a faint seam)")
      ->check(CLI::IsMember(preview::layer_composite_names()))
      ->default_str(preview::layer_composite_name(composite));
  cmd->add_option("--edge-rays", edge_rays,
                  "preview-occlusion: lens rays per pixel traced through the pinhole surface and "
                  "the revealed layers near occluding edges, where layers cannot tell which part "
                  "of the lens sees past an edge (rounded to a square grid; 0, or fewer than 4: "
                  "layers only, faster, more edge error)")
      ->capture_default_str()
      ->check(CLI::Range(0, 1024));
}

void add_request_file_options(CLI::App* cmd, RequestFileOptions& o) {
  cmd->add_option("--request", o.file,
                  "Render the request in this JSON file (as --print-request writes it); options "
                  "given on the command line override its fields");
  cmd->add_flag("--print-request", o.print,
                "Print the resolved request as JSON (what every 'auto' chose) and exit without "
                "rendering");
}

request::RenderRequest apply_request_file(
    const RequestFileOptions& o, const request::RenderRequest& parsed, request::Kind kind,
    const std::function<void(CLI::App*, request::RenderRequest&)>& add_options) {
  if (o.file.empty()) return parsed;
  request::RenderRequest base = request::load_request(o.file);
  if (base.kind != kind)
    throw Error(o.file + ": a request of kind " + request::kind_name(base.kind) + ", not " +
                request::kind_name(kind));
  CLI::App again;
  RequestFileOptions ignored;
  add_options(&again, base);
  add_request_file_options(&again, ignored);
  std::vector<std::string> args(g_command_arguments.rbegin(), g_command_arguments.rend());
  again.parse(args);  // the same options parsed before: cannot fail now
  return base;
}

void print_warnings(const std::vector<std::string>& warnings) {
  for (const std::string& w : warnings) std::fprintf(stderr, "dofcache: warning: %s\n", w.c_str());
}

void print_environment_notices(const render::ResolvedEnvironment& r) {
  print_warnings(r.warnings);
  if (r.default_sky)
    std::fprintf(stderr,
                 "dofcache: notice: the scene has no light; it is lit by a default sky (choose "
                 "one with --env FILE or --env-color R,G,B, or none with --no-default-sky)\n");
}

}  // namespace dofcache::cli
