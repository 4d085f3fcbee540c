#pragma once
// The paper's radiance-cache structure, built as pbrt-v2 builds its irradiance-cache octree: the
// baseline the vdb backend is measured against. Only the structure differs between the two: both
// keep their samples in the same blocks of eight and test them with the same kernel
// (dofcache/cache/sample_blocks.h), so a comparison measures octree against sparse grid, not tuning.
//
// A cubic root whose edge is a power of two grows by doubling towards new samples (re-rooting, the
// old root becoming one of the new root's children) until it contains every sample's sphere. A
// sample of radius r is filed in every node of edge 2^ceil(log2 2r) (the deepest level whose edge
// is >= 2r) that its sphere overlaps: at most 2 per axis, 8 in all, a copy in each (as pbrt-v2
// copies records into the overlapped children). A node's samples are one contiguous range of the
// cache's sample blocks. A lookup walks the nodes containing the point from the root down and
// tests the ranges met on the way together; no sample is met twice because a sample lives on one
// level only, and at most once per node.
#include <memory>

#include "dofcache/cache/radiance_cache.h"

namespace dofcache::cache {

// max_depth bounds the tree below the root; samples smaller than the deepest node allows are
// stored at that depth (still correct, only slower).
std::unique_ptr<RadianceCache> make_octree_radiance_cache(int max_depth = 40);

}  // namespace dofcache::cache
