#pragma once
// Pyramid blur (Kraus & Strengert, GRAPP 2007): reduce with a 4x4 box filter (stride 2), expand
// with biquadratic B-spline interpolation. Reducing to level l and expanding back blurs with a
// smooth kernel whose variance per axis is (derivation in docs/preview.md)
//     V(l) = 0.75 (4^l - 1) px^2:   l = 1: 2.25, l = 2: 11.25, l = 3: 47.25, l = 4: 191.25.
// (the variance of the kernel averaged over the pixel's position in its 2^l cell: the pyramid is
// shift-variant, and per position the kernel is 0.25 px^2 narrower around a centre that moves by
// +-0.5 px). A CoC disk of radius r has variance r^2 / 4 per axis, so level l matches the disk
// radius R(l) = sqrt(3 (4^l - 1)): 0, 3, 6.7, 13.7, 27.7, 55.4 px for l = 0..5.
//
// Radii between two levels: Kraus & Strengert use one level per layer (powers of two, the over-
// blur the paper admits in 3.3). We blend instead: blur = (1 - t) level_l + t level_{l+1} with
// V(l) <= r^2/4 <= V(l+1) and t = (r^2/4 - V(l)) / (V(l+1) - V(l)), which matches the variance of
// the disk exactly (the mixture of two centred kernels has the weighted mean of their variances).
// Being linear, the blend is done at level l (expand l+1 once, mix, expand the mix), so it costs
// one extra reduce and expand at a quarter of the resolution of level l.
//
// Borders: samples outside the image repeat the edge pixel (clamp to edge).
//
// Small radii. Below R(1) = 3 px the blend mixes the unblurred layer with level 1: a kernel that
// is a spike with a wide halo (at r = 1.5 px, 75 % of the weight stays on the pixel), so a small
// defocused silhouette stays almost sharp and opaque on its inner side and gets a faint halo
// outside. The layered preview blurs such layers directly instead, with the separable kernel whose
// 1-D profile is the disk's marginal (disk_profile_taps): it has the disk's variance r^2 / 4 and
// support, and blurs a straight axis-aligned edge exactly as the disk does. (Between R(1) and R(2)
// the level-1/level-2 blend is milder but still a narrow core with a wide skirt; the default
// PreviewOptions::direct_blur_radius covers both ranges.)
#include <vector>

#include "dofcache/image/image.h"

namespace dofcache::preview {

// V(l) above.
double pyramid_level_variance(int level);
// Highest useful level for an image: the one that is 1 pixel in its larger dimension.
int pyramid_max_level(int width, int height);

struct LevelBlend {
  int level = 0;  // l
  float t = 0;    // weight of level l+1 (0 when not blending)
};
// The level(s) that blur like a disk of radius `radius` px (radii below 0.5 px are sharp).
// blend = false: the smallest level with V(l) >= r^2/4 (Kraus & Strengert).
LevelBlend level_blend_for_radius(double radius, int max_level, bool blend);

// The 1-D taps k = -R..R (R = ceil(r - 1/2)) of the disk's marginal density
// (2 / (pi r^2)) sqrt(r^2 - x^2), integrated over each pixel [k - 1/2, k + 1/2]; they sum to one.
// Radii at most 1/2 give the single tap {1}.
std::vector<float> disk_profile_taps(double radius);
// Blur every channel (at most 4) with disk_profile_taps horizontally, then vertically (clamp to
// edge), as the layered preview blurs layers of radius below PreviewOptions::direct_blur_radius.
image::Image disk_profile_blur(const image::Image& image, double radius);

// One reduce step: coarse is ceil(w/2) x ceil(h/2), same channels (at most 4).
void pyramid_reduce(const image::Image& fine, image::Image& coarse);
// One expand step to `fine_width` x `fine_height` (which must reduce to coarse's size).
void pyramid_expand(const image::Image& coarse, int fine_width, int fine_height,
                    image::Image& fine);
// Blur every channel (at most 4) like a disk of `radius` px, by pyramid.
image::Image pyramid_blur(const image::Image& image, double radius, bool blend_levels = true);

}  // namespace dofcache::preview
