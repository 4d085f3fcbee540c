#pragma once
// The OpenVDB radiance cache: world-space sparse grids, one per power-of-two voxel size.
// OpenVDB itself stays inside src/cache/vdb_cache.cpp; this header only names the factory.
//
// Level e has voxel size h_e = 2^e metres, world space (voxel centres on the multiples of h_e), so
// the cache stays valid when the camera moves. A sample of radius r lives on the level
// e = ceil(log2(cell_scale * r)) (h_e >= cell_scale * r), once, in the voxel containing its
// centre. A level's samples are kept sorted by (leaf node, voxel within the leaf), and every voxel
// of the level's Int32Tree holds the index of its first sample, so a run of voxels along z is one
// contiguous range read from two values of one leaf. A lookup visits only the non-empty levels (a
// 64-bit mask) whose sample bounds contain the point; on each it collects the voxel runs that the
// ball of the level's largest radius around the point touches (2 voxels per axis at most with
// cell_scale >= 2), then prefilters all of them eight samples at a time and tests the few in reach.
#include <memory>

#include "dofcache/cache/radiance_cache.h"

namespace dofcache::cache {

struct VdbCacheOptions {
  // Voxel size over sample radius, at least: 1, 2, 4 or 8. Smaller voxels mean fewer candidates
  // per lookup but more voxel runs and more leaf nodes; 4 measured fastest, with the least memory
  // (docs/cache.md).
  float cell_scale = 4.0f;
};

std::unique_ptr<RadianceCache> make_vdb_radiance_cache(const VdbCacheOptions& options = {});

}  // namespace dofcache::cache
