#pragma once
// Command-line options, each mapped onto a field of the one request (request/render_request.h),
// defined once so their names, ranges and help read the same in every command.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "dofcache/render/environment.h"
#include "dofcache/request/render_request.h"

namespace dofcache::cli {

// SCENE (positional), --camera, --scene-index, and the loader's limits on what a file may make
// it allocate: --max-vertices, --max-triangles, --max-texture-pixels, --max-node-depth.
void add_scene_options(CLI::App* cmd, request::RenderRequest& r);
// --width, --height.
void add_size_options(CLI::App* cmd, request::RenderRequest& r);
// --fstop, --focal-length, --focus-distance (render, sequence, view, refocus): each overrides the
// lens the command would otherwise use, which `unset`, if given, names in the help.
void add_lens_options(CLI::App* cmd, render::LensOverrides& lens, const std::string& unset = "");
// --lens-file, --sensor-size, --sensor-fit, --exposure-follows-lens (render, sequence): a real
// lens traced element by element (lens/real_lens.h).
void add_real_lens_options(CLI::App* cmd, render::LensOverrides& lens);
// --seed, --threads.
void add_seed_and_threads(CLI::App* cmd, request::RenderRequest& r, const std::string& seed_help);
// --light-samples, --gather-rays, --bounces, --specular-depth, --rough-lobe-rate,
// --material-override: any of them sets the request's shading (the others keep the renderer's
// defaults).
void add_shading_options(CLI::App* cmd, request::RenderRequest& r);
// --cache (auto, none or a backend) and the tuning: --min-factor, --cache-radius,
// --cache-accuracy, --cache-max-radius, --cache-normal-angle, --cache-min-samples,
// --cache-sample-quality, --cache-direct-*, --cache-sample-rounds, --cache-sample-error.
void add_cache_options(CLI::App* cmd, request::RenderRequest& r, const std::string& cache_help);
// --denoise auto|on|off.
void add_denoise_option(CLI::App* cmd, request::RenderRequest& r);
// --adaptive auto|on|off, --adaptive-pilot, --adaptive-min, --adaptive-max.
void add_adaptive_options(CLI::App* cmd, request::RenderRequest& r);
// The environment light: --env FILE, --env-color R,G,B, --env-strength, --env-rotation,
// --env-visible on|off, --no-default-sky.
void add_environment_options(CLI::App* cmd, render::EnvironmentSettings& environment);
// The layered previews' composite: --layer-composite over|slabs, --edge-rays N.
void add_composite_options(CLI::App* cmd, preview::LayerComposite& composite, int& edge_rays);

// --request FILE and --print-request. A request file is the base; the options given on the
// command line override its fields (apply_request_file parses them again onto it).
struct RequestFileOptions {
  std::string file;
  bool print = false;
};
void add_request_file_options(CLI::App* cmd, RequestFileOptions& o);
// The request to run: `parsed` as the command line gave it, or, with --request, the file's
// request with the command line's options applied again by `add_options` (the command's own
// registration) onto it. The file's kind must be `kind`.
request::RenderRequest apply_request_file(
    const RequestFileOptions& o, const request::RenderRequest& parsed, request::Kind kind,
    const std::function<void(CLI::App*, request::RenderRequest&)>& add_options);

// The command line's arguments after the command's name (main records them).
void set_command_arguments(std::vector<std::string> args);

// On stderr, once the render is about to start (so that a failing run prints its one error line
// alone): the scene's and the environment's warnings and, when the scene has no light and gets the
// default sky, a one-line notice naming the options.
void print_warnings(const std::vector<std::string>& warnings);
void print_environment_notices(const render::ResolvedEnvironment& environment);

}  // namespace dofcache::cli
