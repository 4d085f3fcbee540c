#pragma once
// The preview mode end to end: the renderer supplies the pinhole images (and, for the occlusion
// fix, the near-plane id layers and the revealed layers), the post-process makes the depth-of-field
// image (paper section 3; docs/preview.md).
//
// For LayeredOcclusion (paper 3.2):
//   1. plan = plan_layers(pinhole depth, imaging, options);
//   2. L_j for j = 1..n-1: visibility through the pixel centres with the near plane at z_j,
//      triangle ids. Only pixels whose pinhole surface the plane clips are traced, and of those
//      only the ones the masks read (lens_reach_regions, occlusion.h); elsewhere L_j = L_0 (the
//      pinhole hit is the nearest one beyond the plane too), which gives the same masks as tracing
//      every clipped pixel. L_j of a plane behind every surface (or at infinity) is empty;
//   3. masks = build_occlusion_masks(L, depth, plan, imaging, options);
//   4. A_j: colour (the same pinhole samples per pixel) and depth with the near plane at z_j,
//      only where mask_j is set.
// The other methods need the pinhole render only.
#include <cstdint>

#include "dofcache/image/image.h"
#include "dofcache/preview/layers.h"
#include "dofcache/preview/options.h"
#include "dofcache/preview/preview.h"
#include "dofcache/preview/refocus.h"
#include "dofcache/render/renderer.h"
#include "dofcache/scene/accel.h"
#include "dofcache/scene/scene.h"

namespace dofcache::preview {

// Wall-clock milliseconds per stage, the columns of the paper's Table 3.1.
struct ScenePreviewTimings {
  double pinhole_render_ms = 0;  // colour (settings.spp pinhole samples), depth, ids
  double denoise_ms = 0;         // the pinhole colour denoised (PreviewOptions::denoise)
  double id_render_ms = 0;       // near-plane id images L_1..L_{n-1}
  double mask_build_ms = 0;      // build_occlusion_masks
  double extra_render_ms = 0;    // the revealed layers A_j, masked pixels only
  double postprocess_ms = 0;     // render_preview
  double total_ms = 0;
  // The paper's "extra-region mask" column: id renders and mask building together.
  double mask_ms() const { return id_render_ms + mask_build_ms; }

  PreviewTimings postprocess;         // the post-process's own split
  int layers = 0;                     // layers planned (layered methods)
  int revealed_layers = 0;            // revealed layers with a non-empty mask
  std::uint64_t revealed_pixels = 0;  // pixels rendered again, summed over the revealed layers
  std::uint64_t id_pixels = 0;        // pixels traced for the id layers, summed over L_1..L_{n-1}
  render::RenderStats pinhole_stats;
};

struct ScenePreview {
  image::Image image;         // the preview (linear RGB)
  PreviewInputs inputs;       // what the post-process was given
  RevealedCoverage coverage;  // what the revealed layers cover (for refocusing)
  ScenePreviewTimings timings;
};

// What preview inputs are rendered with for a quick look (the defaults of `render --mode
// preview*` and the viewer's first stages): one pinhole sample per pixel, and shading cut down
// from `full` to one light sample and mirrors one level deep, plus, if `indirect`, two gather rays
// of one bounce (else direct light only). The post-process blurs most of the noise this leaves.
constexpr int kQuickInputSpp = 1;
render::ShadingSettings quick_input_shading(const render::ShadingSettings& full, bool indirect);

// The pinhole inputs of the preview (steps 1-4 above) without the post-process: what
// refocus_inputs() and render_preview() take, e.g. for a viewer that refocuses them on demand.
// Arguments as render_scene_preview's; timings.postprocess* stay zero.
struct SceneInputs {
  PreviewInputs inputs;
  RevealedCoverage coverage;
  ScenePreviewTimings timings;
};
SceneInputs render_preview_inputs(const scene::Scene& scene, const scene::Accel& accel,
                                  const scene::Camera& camera,
                                  const render::RenderSettings& settings, PreviewMethod method,
                                  const PreviewOptions& options = {});

// `in` (without revealed layers) at width x height, every pixel taking the nearest source pixel's
// colour, depth and id (never a blend: a depth or id between two surfaces belongs to neither),
// the imaging's resolution set to the new height. For a first look rendered at a fraction of the
// size. Throws dofcache::Error if `in` has revealed layers or the size is not positive.
PreviewInputs upscale_inputs(const PreviewInputs& in, int width, int height);

// Renders the preview of `camera`'s view. `settings` supplies the size, pinhole samples per pixel
// (spp), seed, threads, shading, lens and progress display; its mode, near plane, mask and
// visibility flag are ignored, and a radiance cache is refused (pinhole renders do not use one).
// `options.threads` applies to the post-process. Throws dofcache::Error on invalid settings.
ScenePreview render_scene_preview(const scene::Scene& scene, const scene::Accel& accel,
                                  const scene::Camera& camera,
                                  const render::RenderSettings& settings, PreviewMethod method,
                                  const PreviewOptions& options = {});

}  // namespace dofcache::preview
