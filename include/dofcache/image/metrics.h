#pragma once
// Image error metrics for comparing cached / preview renders against a converged reference.
#include <optional>

#include "dofcache/image/image.h"

namespace dofcache::image {

// PSNR of identical images is infinite; it is reported as this cap instead, so tables and JSON
// stay finite.
constexpr double kPsnrCapDb = 100.0;

struct ErrorMetrics {
  double rel_mse = 0;  // mean over pixels and channels of (a-b)^2 / (b^2 + 1e-2), b the reference
  double mse = 0;      // mean over pixels and channels of (a-b)^2, unclamped linear values
  double psnr = 0;     // dB, peak 1, from the MSE of values clamped to [0,1] (as displayed);
                       // capped at kPsnrCapDb
  double ssim = 0;     // mean SSIM of the Rec.709 luminance (RGB clamped to [0,1] first), Gaussian
                       // 11x11 window with sigma 1.5, C1 = 0.01^2, C2 = 0.03^2 (Wang et al. 2004);
                       // at the borders the window is cut off and renormalised
};

// `test` against `reference`. `mask` (1 channel, same size), if given, restricts the metrics to
// pixels where mask > 0.5 (SSIM: windows centred there). Throws dofcache::Error (naming both
// sizes) if shapes differ, or if the mask has the wrong shape or selects no pixel. Parallel (TBB),
// with the same result for any number of threads.
ErrorMetrics compare(const Image& test, const Image& reference, const Image* mask = nullptr);

// Per-pixel relative squared error (1 channel, the mean over channels of the rel_mse term), for
// error-map figures. Throws dofcache::Error if shapes differ.
Image relative_error_map(const Image& test, const Image& reference);

// Maps a 1-channel error image to a false-colour RGB image (0 -> black, `max_value` -> white)
// along a perceptual ramp black -> purple -> orange -> yellow -> white. The ramp is defined in
// display (sRGB) values and returned as linear RGB, so write_image(".png") shows it as designed.
// Values above max_value (and NaN) saturate to white. Throws dofcache::Error unless `values` has
// 1 channel and max_value > 0.
Image false_color(const Image& values, double max_value);

}  // namespace dofcache::image
