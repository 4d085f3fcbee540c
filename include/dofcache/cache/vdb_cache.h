#pragma once
// The OpenVDB radiance cache: world-space sparse grids, one per power-of-two voxel size.
// OpenVDB itself stays inside src/cache/vdb_cache.cpp; this header only names the factory.
//
// Level e has voxel size h_e = 2^e metres, world space (voxel centres on the multiples of h_e), so
// the cache stays valid when the camera moves. A sample of radius r lives on the level
// e = ceil(log2(cell_scale * r)) (h_e >= cell_scale * r), copied into every voxel that the box of
// its sphere touches (1-2 per axis with cell_scale >= 2; the copy in its centre's voxel is its
// home, which size() and for_each_sample() count), so a lookup reads one voxel per level. A
// level's copies are kept sorted by (leaf node, voxel within the leaf), and every voxel of the
// level's Int32Tree holds the index of its first copy, so a voxel's copies are one contiguous
// range read from two values of one leaf. A lookup visits only the non-empty levels (a 64-bit
// mask) whose sample bounds contain the point; on each it probes the point's voxel, then
// prefilters that voxel's copies eight at a time and tests the few in reach.
#include <memory>

#include "dofcache/cache/radiance_cache.h"

namespace dofcache::cache {

struct VdbCacheOptions {
  // Voxel size over sample radius, at least: 1, 2, 4 or 8. Smaller voxels mean fewer candidates
  // per lookup but more copies of each sample (memory); 4 measured fastest at half the octree's
  // memory (docs/cache.md).
  float cell_scale = 4.0f;
};

std::unique_ptr<RadianceCache> make_vdb_radiance_cache(const VdbCacheOptions& options = {});

}  // namespace dofcache::cache
