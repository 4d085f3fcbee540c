#pragma once
// Normalised pull-push interpolation (Strengert, Kraus & Ertl 2006): the disocclusion step of the
// layered preview, which fills culled foreground pixels with colours interpolated from the
// surrounding pixels so that blurring the layer does not darken its edges.
//
// Pull: level l+1 is a weighted reduce of level l: value = sum(w v) / sum(w), weight =
//       min(1, sum(w)) (a coarse pixel with one fully known child counts as known); a 2x2 box to
//       level 1, then the overlapping tent [1 3 3 1] / 4 per axis, so that a hole's pixels next to
//       known ones are filled from them even where the hole's edge falls on cell boundaries. (The
//       layered preview's over composite pulls with the 2x2 box on every level, as Kraus &
//       Strengert do; its slab composite with the tent.)
// Push: from the coarsest level (1x1) down, every pixel with weight w < 1 becomes
//       w v + (1 - w) bilinear(coarser filled level); pixels with weight >= 1 are kept.
// Values are stored unpremultiplied beside their weight, so every filled value is a normalised
// (weights summing to one) combination of known values: no dark halos, constants stay constant.
#include "dofcache/image/image.h"

namespace dofcache::preview {

// Fills `values` (any channel count, at most 8) in place wherever `weight` (1 channel, same size,
// in [0, 1]) is below one. Pixels with weight >= 1 are left bit-identical; pixels with weight 0
// may hold anything (even NaN), they are never read. If no pixel has a positive weight, the holes
// become 0. Parallel (TBB).
void pull_push_fill(image::Image& values, const image::Image& weight);

}  // namespace dofcache::preview
