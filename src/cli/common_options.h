#pragma once
// Command-line options shared by the rendering commands (render, sequence), defined once so
// their names, ranges and help read the same everywhere.
#include <cstdint>
#include <optional>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "dofcache/preview/options.h"
#include "dofcache/render/environment.h"
#include "dofcache/render/renderer.h"
#include "dofcache/scene/gltf_loader.h"

namespace dofcache::cli {

// SCENE (positional), --camera, --scene-index, and the loader's limits on what a file may make
// it allocate: --max-vertices, --max-triangles, --max-texture-pixels, --max-node-depth.
void add_scene_options(CLI::App* cmd, std::string& scene_path, std::string& camera,
                       int& scene_index, scene::LoadLimits& limits);
// --width, --height.
void add_size_options(CLI::App* cmd, int& width, int& height);
// --fstop, --focal-length, --focus-distance (render, sequence, refocus): each overrides the lens
// the command would otherwise use (the camera's extras.lens; refocus: the saved lens), which
// `unset`, if given, names in the help ("default: <unset>").
void add_lens_options(CLI::App* cmd, std::optional<double>& fstop,
                      std::optional<double>& focal_length, std::optional<double>& focus_distance,
                      const std::string& unset = "");
// --seed, --threads.
void add_seed_and_threads(CLI::App* cmd, std::uint64_t& seed, int& threads,
                          const std::string& seed_help);
// --light-samples, --gather-rays, --bounces, --specular-depth.
void add_shading_options(CLI::App* cmd, render::ShadingSettings& shading);
// --min-factor, --cache-radius, --cache-accuracy, --cache-max-radius, --cache-normal-angle,
// --cache-min-samples, --cache-sample-quality (the backend option --cache is each command's own).
void add_cache_tuning_options(CLI::App* cmd, render::CacheSettings& cache);

// The environment light (render, sequence): --env FILE, --env-color R,G,B, --env-strength,
// --env-rotation, --env-visible on|off, --no-default-sky.
void add_environment_options(CLI::App* cmd, render::EnvironmentSettings& environment);
// On stderr, once the render is about to start (so that a failing run prints its one error line
// alone): the environment's warnings and, when the scene has no light and gets the default sky,
// a one-line notice naming the options.
void print_environment_notices(const render::ResolvedEnvironment& environment);
// The environment as statistics files record it: {"kind", "description", "strength",
// "rotation_deg", "visible", "path"}.
nlohmann::json environment_json(const render::EnvironmentSettings& settings,
                                const render::ResolvedEnvironment& environment);

// The cache settings as every statistics file records them (render and sequence --stats-json,
// one writer so both use the same keys): backend, radius_rule, min_factor, accuracy,
// max_radius_pixels, sample_quality (as the render uses it: "auto" resolved), max_normal_angle_deg,
// min_samples.
nlohmann::json cache_settings_json(const std::string& backend,
                                   const render::RenderSettings& settings);

// The layered previews' composite (render and refocus): --layer-composite over|slabs and
// --edge-rays N, into options.layer_composite and options.edge_rays.
void add_composite_options(CLI::App* cmd, preview::PreviewOptions& options);
// Copies the fields add_composite_options sets from `flags` into `options`.
void apply_composite_options(const preview::PreviewOptions& flags,
                             preview::PreviewOptions& options);

}  // namespace dofcache::cli
