#pragma once
// A resolved image request rendered and written: the integrators (with the radiance cache the
// request names) or a preview, the image and its depth, normal and id channels, the preview inputs
// for `refocus`, the cache's debug images and trace, and the statistics file. What `render` does;
// the CLI only prints the result.
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "dofcache/preview/preview_renderer.h"
#include "dofcache/render/renderer.h"
#include "dofcache/request/resolve.h"

namespace dofcache::request {

struct ImageResult {
  std::optional<render::RenderOutput> render;    // the integrators
  // With --denoise on (integrators): render->color filtered (denoised()); render->color stays raw.
  std::optional<image::Image> denoised;
  double denoise_seconds = 0.0;
  std::optional<preview::ScenePreview> preview;  // the preview modes
  // The statistics file's contents (written if the request names one): the scene, the settings as
  // the render used them, timings, ray counts and the cache's counters.
  nlohmann::json stats;
};

// Renders `resolved` (resolve() of an Image request for this scene and camera) and writes every
// output atomically. Throws dofcache::Error.
ImageResult render_image(const ResolvedRequest& resolved, const scene::Scene& scene,
                         const scene::Accel& accel, const scene::Camera& camera);

// The denoised colour of an integrator's render made with RenderSettings::lens_features
// (denoise/render_filter.h, guided by its lens features and its circles of confusion; a pinhole
// render is sharp everywhere). Throws dofcache::Error if the render kept no lens features.
image::Image denoised(const render::RenderOutput& out, const render::RenderSettings& settings,
                      const scene::Camera& camera);

// An integrator's image file, atomically: its colour (with `denoised`, that for an 8-bit file;
// an EXR keeps the raw render, with the denoised colour and the denoiser's guides as layers beside
// it) and the centre ray's depth, normal and id. What `render` and `sequence` write.
// A real lens (settings.real_lens) is recorded in an EXR's header (lens::real_lens_attributes).
void write_render(const std::string& path, const render::RenderOutput& out,
                  const std::optional<image::Image>& denoised,
                  const lens::MountedLens& real_lens = {});

// What is about to be rendered, in words, as `render` prints it: the scene, the environment, a
// synthesized camera, the camera and lens. Each line ends with a newline.
std::string describe_setup(const ResolvedRequest& resolved, const scene::Scene& scene,
                           const scene::Camera& camera);

// What the render did, in words, as `render` prints it: one line for an integrator (size, mode,
// spp, threads, time, ray rate) plus one for its cache, or two for a preview (method, layers,
// the stages' times). Each line ends with a newline.
std::string describe(const ResolvedRequest& resolved, const ImageResult& result);

// The environment as statistics files record it: {"kind", "description", "strength",
// "rotation_deg", "visible", "mean_radiance", "path"}.
nlohmann::json environment_json(const render::EnvironmentSettings& settings,
                                const render::ResolvedEnvironment& environment);

}  // namespace dofcache::request
