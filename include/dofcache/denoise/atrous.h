#pragma once
// Denoising guided by noise-free features: the edge-avoiding a-trous wavelet filter of Dammertz et
// al. 2010 ("Edge-avoiding a-trous wavelet transform for fast global illumination filtering"),
// with the variance-guided luminance weight of SVGF (Schied et al. 2017) in its spatial form.
//
// A pinhole render's albedo, normal, depth and object id through the pixel centres are free of
// noise at one sample per pixel, so they steer the filter. The colour is demodulated by the albedo
// (texture detail is not blurred: it is put back afterwards), the irradiance filtered in
// iterations of a 5x5 B3-spline kernel whose taps spread 1, 2, 4, ... pixels apart, each tap
// weighted by
//   w = h(dx) h(dy) [same id] (n_p . n_q)^sigma_normal exp(-|z_p - z_q| / (sigma_depth |grad z| d))
//       exp(-|l_p - l_q| / (sigma_luminance sqrt(var_p))),
// var_p the local luminance variance of the demodulated input, filtered along with it. Pixels
// that see nothing keep their colour and take no part. Debian packages no Open Image Denoise
// (docs/denoise.md says why this is written here).
#include "dofcache/image/image.h"

namespace dofcache::denoise {

struct Guides {
  const image::Image* albedo = nullptr;  // RGB, diffuse albedo at the first hit (required)
  const image::Image* normal = nullptr;  // RGB, world-space shading normal (required)
  const image::Image* depth = nullptr;   // 1 channel, camera-space depth; +inf: nothing seen
  const image::Image* ids = nullptr;     // 1 channel, object id (required)
};

struct AtrousOptions {
  int iterations = 3;             // taps 1, 2, 4 pixels apart: a footprint of 15 pixels
  float sigma_normal = 64.0f;     // exponent of the normal weight
  float sigma_depth = 1.0f;       // depth steps allowed, in units of the local depth gradient
  float sigma_luminance = 4.0f;   // luminance steps allowed, in local standard deviations
  float albedo_floor = 0.02f;     // colour / max(albedo, floor): black albedo divides by this
  int variance_radius = 2;        // the local variance's window: (2r + 1)^2 pixels
  int threads = 0;                // core/threads.h
};

// `color` (RGB, linear) filtered. Throws dofcache::Error unless every guide is given with the
// colour's size and its channel count.
image::Image atrous_filter(const image::Image& color, const Guides& guides,
                           const AtrousOptions& options = {});

}  // namespace dofcache::denoise
