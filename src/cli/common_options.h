#pragma once
// Command-line options shared by the rendering commands (render, sequence), defined once so
// their names, ranges and help read the same everywhere.
#include <cstdint>
#include <optional>
#include <string>

#include <CLI/CLI.hpp>

#include "dofcache/preview/options.h"
#include "dofcache/render/renderer.h"

namespace dofcache::cli {

// SCENE (positional), --camera, --scene-index.
void add_scene_options(CLI::App* cmd, std::string& scene_path, std::string& camera,
                       int& scene_index);
// --width, --height.
void add_size_options(CLI::App* cmd, int& width, int& height);
// --fstop, --focal-length, --focus-distance (each overrides the camera's extras.lens).
void add_lens_options(CLI::App* cmd, std::optional<double>& fstop,
                      std::optional<double>& focal_length, std::optional<double>& focus_distance);
// --seed, --threads.
void add_seed_and_threads(CLI::App* cmd, std::uint64_t& seed, int& threads,
                          const std::string& seed_help);
// --light-samples, --gather-rays, --bounces, --specular-depth.
void add_shading_options(CLI::App* cmd, render::ShadingSettings& shading);
// --min-factor, --cache-radius, --cache-accuracy, --cache-max-radius, --cache-normal-angle,
// --cache-min-samples, --cache-sample-quality (the backend option --cache is each command's own).
void add_cache_tuning_options(CLI::App* cmd, render::CacheSettings& cache,
                              std::string& radius_rule);

// The layered previews' composite (render and refocus): --layer-composite over|slabs and
// --edge-rays N, into options.layer_composite and options.edge_rays.
void add_composite_options(CLI::App* cmd, preview::PreviewOptions& options);
// Copies the fields add_composite_options sets from `flags` into `options`.
void apply_composite_options(const preview::PreviewOptions& flags,
                             preview::PreviewOptions& options);

}  // namespace dofcache::cli
