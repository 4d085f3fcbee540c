#pragma once
// The paper's radiance-cache structure, built as pbrt-v2 builds its irradiance-cache octree: the
// honest baseline the vdb backend is measured against.
//
// A cubic root whose edge is a power of two grows by doubling towards new samples (re-rooting, the
// old root becoming one of the new root's children) until it contains every sample's sphere. A
// sample of radius r is stored, as an index, in every node of edge 2^ceil(log2 2r) (the deepest
// level whose edge is >= 2r) that its sphere overlaps: at most 2 per axis, 8 in all. A lookup
// walks the nodes containing the point from the root down and tests every sample stored on the
// way; no sample is met twice because a sample lives on one level only.
#include <cstdint>
#include <vector>

#include <glm/vec3.hpp>

#include "dofcache/cache/radiance_cache.h"
#include "dofcache/cache/sample_store.h"

namespace dofcache::cache {

class OctreeRadianceCache final : public RadianceCache {
 public:
  // max_depth bounds the tree below the root; samples smaller than the deepest node allows are
  // stored at that depth (still correct, only slower).
  explicit OctreeRadianceCache(int max_depth = 40);

  std::string name() const override { return "octree"; }
  bool lookup(glm::vec3 p, glm::vec3 n, const LookupOptions& options,
              LookupResult* out) const override;
  std::size_t size() const override { return store_.size(); }
  std::size_t memory_bytes() const override;
  void for_each_sample(const std::function<void(const CacheSample&)>& fn) const override;

  int depth() const;  // levels below the root actually used

 protected:
  void add_samples(const std::vector<CacheSample>& samples) override;
  void remove_all() override;

 private:
  struct Node {
    std::uint32_t child[8] = {};         // 0: no child (the root, node 0, is nobody's child)
    std::vector<std::uint32_t> samples;  // indices into store_
  };

  void grow_root(glm::dvec3 lo, glm::dvec3 hi);
  void add_to(std::uint32_t node, glm::dvec3 origin, int exponent, int target, std::uint32_t slot);

  int max_depth_;
  std::vector<Node> nodes_;
  glm::dvec3 root_origin_{0.0};
  int root_exponent_ = 0;  // root edge = 2^root_exponent_
  SampleStore store_;
};

}  // namespace dofcache::cache
