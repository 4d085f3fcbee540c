#pragma once
// Samples created by one render tile during a pass, before the pass-end merge into the
// RadianceCache. A tile looks here after the (read-only) cache misses, so it reuses its own new
// samples at once; other tiles never see them until the merge, which keeps renders independent of
// the thread count. Not shared between threads.
#include <cstddef>
#include <vector>

#include <glm/vec3.hpp>

#include "dofcache/cache/sample.h"
#include "dofcache/cache/sample_blocks.h"

namespace dofcache::cache {

class TileSampleBuffer {
 public:
  // Stores s with a tile-local id (its index), so lookups here sum in creation order.
  void add(const CacheSample& s);

  // The same tests, weights and summation as RadianceCache::lookup, over this tile's samples.
  bool lookup(glm::vec3 p, glm::vec3 n, const LookupOptions& options, LookupResult* out) const;

  std::size_t size() const { return samples_.size(); }
  bool empty() const { return samples_.empty(); }
  const std::vector<CacheSample>& samples() const { return samples_; }
  // Appends the samples to a pass-end batch for RadianceCache::insert (which reassigns ids).
  void append_to(std::vector<CacheSample>* batch) const;
  void clear();

 private:
  std::vector<CacheSample> samples_;
  BlockSamples blocks_;  // the same samples, laid out for lookups
  glm::vec3 lo_{0.0f}, hi_{0.0f};  // bounds of the samples' spheres
};

}  // namespace dofcache::cache
