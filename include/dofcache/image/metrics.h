#pragma once
// Image error metrics for comparing cached / preview renders against a converged reference.
#include <optional>

#include "dofcache/image/image.h"

namespace dofcache::image {

struct ErrorMetrics {
  double rel_mse = 0;  // mean over pixels and channels of (a-b)^2 / (b^2 + 1e-2), b the reference
  double mse = 0;
  double psnr = 0;     // dB, with peak 1 (values clamped to [0,1] first, as displayed)
  double ssim = 0;     // mean SSIM of the luminance, 8x8 windows (Wang et al. 2004 constants)
};

// `test` against `reference`; throws dofcache::Error if shapes differ. `mask` (1 channel, same
// size), if given, restricts the metrics to pixels where mask > 0.5 (SSIM: windows centred there).
ErrorMetrics compare(const Image& test, const Image& reference, const Image* mask = nullptr);

// Per-pixel relative squared error (1 channel), for error-map figures.
Image relative_error_map(const Image& test, const Image& reference);

// Maps a 1-channel error image to a false-colour RGB image (0 -> black, `max_value` -> white).
Image false_color(const Image& values, double max_value);

}  // namespace dofcache::image
