#pragma once
// Single-layer post-process baselines, for comparison with the layered preview.
//
// gather_blur (reverse mapping). Output pixel p averages the pixels q in the disk of the largest
// radius that can reach it, with weight [|p - q| <= r_eff + 0.5] / max(1, pi (r_q + 0.5)^2)
// (a point spreads its colour over its own CoC disk, so its density is one over the disk area),
// normalised by the sum of weights. Foreground-bleeding guard (the depth-ordered reach test of
// scatter-as-gather filters): a neighbour nearer than p reaches p with its own radius,
// r_eff = r_q; a neighbour at p's depth or behind it reaches p only within p's radius too,
// r_eff = min(r_q, r_p). Hence
//   * a sharp in-focus pixel (r_q ~ 0) never leaks onto a blurred background beside it: its
//     colour stays inside its own CoC;
//   * a blurred background never spreads over a sharp foreground (min(r_q, r_p) ~ 0);
//   * a blurred foreground does spread over a sharp background (partial occlusion, to the extent
//     a single layer can show it).
// For neighbours at or behind p this is exactly "average the neighbours inside p's CoC disk whose
// own CoC reaches p"; only nearer neighbours may reach from farther away. The search radius of a
// pixel is the largest radius in the surrounding 16x16 tiles.
//
// scatter_blur (forward mapping). Every pixel splats its CoC disk (radius r + 0.5, discrete disk,
// density one over its pixel count) as row spans through per-row difference buffers. Pixels are
// sorted into depth bins of options.scatter_bin_width px of signed CoC; splats of one bin add up
// (colour sum C_b, weight sum W_b) and the bins are composited far to near with "over":
// alpha_b = min(1, W_b), colour_b = C_b / W_b, so near splats cover far ones where they cover the
// pixel fully, and let them through at their soft edges. The result is normalised by the total
// alpha.
//
// Both: radii are |c| / 2 clamped to options.max_coc_radius; r <= 0.5 px is sharp (the pixel
// itself only), so an in-focus image is returned unchanged. Parallel (TBB).
#include "dofcache/image/image.h"
#include "dofcache/lens/thin_lens.h"
#include "dofcache/preview/options.h"

namespace dofcache::preview {

image::Image gather_blur(const image::Image& color, const image::Image& depth,
                         const lens::LensImaging& imaging, const PreviewOptions& options = {});
image::Image scatter_blur(const image::Image& color, const image::Image& depth,
                          const lens::LensImaging& imaging, const PreviewOptions& options = {});

}  // namespace dofcache::preview
