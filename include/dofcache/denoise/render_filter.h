#pragma once
// Denoising of a lens-integrated render (drt, accumulation): the edge-avoiding a-trous filter of
// Dammertz et al. 2010 steered by what the render measured itself, as in SVGF (Schied et al.
// 2017) but spatial only, and made aware of the depth of field.
//
// A render's features through the pixel centres are sharp where its colour is blurred, so a
// filter guided by them would cut a bokeh disc along the edges of the objects behind it. Here the
// guides are the first hits averaged over the same lens samples as the colour (render::
// LensFeatures): albedo, normal and coverage blur exactly where the colour does. Each pixel's
// circle of confusion says which guide is sharp: where it is under `focus_coc_pixels`, the centre
// ray's object id and depth hold as in the quick look's filter (an in-focus edge is never
// crossed); where it is larger, the averaged normal steers, with an exponent that softens as the
// circle grows (the averages mix surfaces there), and the colour steps decide the rest.
//
// The colour weight compares luminance steps with the pixel's own measured noise: the variance of
// its mean from its lens samples, demodulated by the albedo and lightly blurred (3x3) because at a
// few samples it is itself noisy; it is propagated through the iterations (var' = sum w^2 var /
// (sum w)^2). A lone bright sample (a firefly) raises only its own pixel's variance: its
// neighbours, whose noise is small, refuse it, while it takes their values.
// Each tap's weight:
//   w = h(dx) h(dy) (n_p . n_q)^(sigma_normal / (1 + coc_p)) exp(-|l_p - l_q| / (sigma_luminance
//       sqrt(var_p)))   [in focus: same id, exp(-|z_p - z_q| / (sigma_depth |grad z| d))]
#include "dofcache/image/image.h"
#include "dofcache/lens/thin_lens.h"

namespace dofcache::denoise {

struct RenderGuides {
  // Averaged over the pixel's lens samples (render::LensFeatures); all required.
  const image::Image* albedo = nullptr;    // RGB, over the same samples as `color`
  // RGB: the same from more samples (render::LensFeatures), which remodulates the filtered light.
  const image::Image* albedo_estimate = nullptr;
  const image::Image* normal = nullptr;    // RGB, not unit length where surfaces mix
  const image::Image* coverage = nullptr;  // 1 channel: fraction of samples that hit (0: none)
  const image::Image* emission = nullptr;  // RGB: emitted and background radiance in `color`
  // RGB: the same from more samples (render::LensFeatures), and its mean luminance's variance.
  const image::Image* emission_estimate = nullptr;
  const image::Image* emission_variance = nullptr;
  const image::Image* variance = nullptr;  // 1 channel: variance of the mean reflected luminance
  // Through the pixel centre (render::RenderOutput::depth, ids); required.
  const image::Image* depth = nullptr;
  const image::Image* ids = nullptr;
  // 1 channel: the circle of confusion's radius in pixels (coc_radius_image); required.
  const image::Image* coc = nullptr;
};

struct RenderFilterOptions {
  int iterations = 4;              // taps 1 to 8 pixels apart: a footprint of 31 pixels
  float sigma_normal = 64.0f;      // the normal weight's exponent in focus
  float sigma_depth = 1.0f;        // in focus: depth steps allowed, in local depth gradients
  float sigma_luminance = 4.0f;    // luminance steps allowed, in standard deviations of the noise
  float albedo_floor = 0.02f;      // colour / max(albedo, floor)
  float focus_coc_pixels = 1.0f;   // a circle of confusion's radius under which a pixel is sharp
  int threads = 0;                 // core/threads.h
};

// Per pixel, the larger circle-of-confusion radius (pixels) of the centre depth and of the lens
// samples' mean depth (a pixel on an in-focus surface behind a defocused edge sees both); 0 where
// neither is finite. Throws dofcache::Error unless both are 1-channel images of one size.
image::Image coc_radius_image(const image::Image& centre_depth, const image::Image& lens_depth,
                              const lens::LensImaging& imaging);

// `color` (RGB, linear) filtered in two parts: the reflected light (colour less emission),
// demodulated by the albedo and steered by every guide, where a lens sample hit a surface; and the
// emission estimate, steered by its own measured noise alone within each pixel's circle of
// confusion, added in place of the colour's emission. Throws
// dofcache::Error unless every guide is given with the colour's size and its channel count.
image::Image render_filter(const image::Image& color, const RenderGuides& guides,
                           const RenderFilterOptions& options = {});

}  // namespace dofcache::denoise
