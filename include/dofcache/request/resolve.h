#pragma once
// resolve(): the one place a request's automatic choices are made. Every front end renders what
// it returns, so `render`, a one-frame `sequence`, a farm job and the viewer's reference agree
// wherever their kinds' rules agree.
//
// The rules (each recorded in ResolvedRequest::choices):
//   height   0: from the camera's aspect ratio (render::height_for_width);
//   spp      unset: 16; preview modes preview::kQuickInputSpp (a quick look: the post-process
//            blurs most of the inputs' noise);
//   shading  unset: the renderer's defaults; preview modes preview::quick_input_shading;
//   cache    auto: image and view requests use the vdb backend where the mode integrates the lens
//            (drt, accumulation; measured at least as fast as the best uncached shading at equal
//            error, docs/peer.md) and none otherwise; a sequence uses vdb when persistent, else
//            none;
//   adaptive auto: on for drt images and the viewer's drt reference, off otherwise (sequences keep
//            one sample count for every pixel of every frame);
//   sample quality render::kAutoSampleQuality: recommended_sample_quality(spp, gather rays); the
//            viewer's passes share one cache, so for it that of 64 lens samples;
//   lens     each unset value from the camera's extras.lens, else 50 mm f/4 focused on what the
//            image centre sees (render::resolve_lens);
//   denoise  auto: on for the preview modes and the viewer's inputs (their pinhole colour is
//            denoised before the post-process) and for an integrator's image or frames written
//            as PNG; off for EXR (the beauty stays the raw render) and for library callers
//            without an output;
//   threads  0: core/threads.h's rule under the request's core policy.
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "dofcache/preview/options.h"
#include "dofcache/render/environment.h"
#include "dofcache/render/renderer.h"
#include "dofcache/request/render_request.h"
#include "dofcache/scene/accel.h"
#include "dofcache/scene/scene.h"

namespace dofcache::request {

struct ResolvedRequest {
  // The request with every automatic choice made (cache backend, adaptive on or off, spp,
  // shading, height, sample quality; for images also the lens): resolving it again changes
  // nothing. Threads stay as asked (0 is a rule of the machine that renders, not a number).
  RenderRequest request;
  // Ready for render::render or preview::render_scene_preview; the cache pointer, frame and
  // trace are the caller's.
  render::RenderSettings settings;
  std::string cache_backend;                     // "none", "octree" or "vdb"
  std::optional<preview::PreviewMethod> preview;  // set for the preview modes
  preview::PreviewOptions preview_options;
  render::ResolvedEnvironment environment;
  bool focus_from_scene = false;  // the lens focus came from probing the scene (autofocus)
  // One line per automatic choice: "cache: auto -> vdb (drt integrates the lens)".
  std::vector<std::string> choices;
};

// Resolves `request` for `scene` (loaded from request.scene) seen through `camera`. Validates
// everything that can be checked before rendering, an image's outputs included (none for an
// image request without an output: a library caller that writes its own); throws
// dofcache::Error.
ResolvedRequest resolve(const RenderRequest& request, const scene::Scene& scene,
                        const scene::Accel& accel, const scene::Camera& camera);

// The checks of an image request that need no scene (its outputs, the options that exclude each
// other), so that a front end fails before it loads one; resolve() makes them too. Nothing for a
// request without an output. Throws dofcache::Error.
void check_image_request(const RenderRequest& request);

// What `render --print-request` prints: to_json(resolved.request) with the choices made, under
// "choices" (ignored when the file is read back).
nlohmann::json resolved_json(const ResolvedRequest& resolved);

}  // namespace dofcache::request
