#include "dofcache/cache/tile_buffer.h"

#include <glm/common.hpp>
#include <glm/vector_relational.hpp>

namespace dofcache::cache {

void TileSampleBuffer::add(const CacheSample& s) {
  CacheSample local = s;
  local.id = static_cast<std::uint32_t>(samples_.size());
  // Bounds of the spheres, padded so that no rounding of the float acceptance test can accept a
  // point outside them.
  float r = 1.001f * s.radius;
  glm::vec3 lo = s.position - r, hi = s.position + r;
  lo_ = samples_.empty() ? lo : glm::min(lo_, lo);
  hi_ = samples_.empty() ? hi : glm::max(hi_, hi);
  samples_.push_back(local);
  blocks_.push_back(local);
}

bool TileSampleBuffer::lookup(glm::vec3 p, glm::vec3 n, const LookupOptions& options,
                              LookupResult* out) const {
  WeightedSum sum;
  // A tile holds a few hundred samples at most: a linear scan, eight samples at a time, beats
  // building any structure. The bounds test skips points no sample of the tile can reach.
  if (!samples_.empty() && glm::all(glm::greaterThanEqual(p, lo_)) &&
      glm::all(glm::lessThanEqual(p, hi_))) {
    SampleTest test(p, n, options);
    RangeScanner scanner(test, &sum);
    scanner.add(&blocks_, 0, static_cast<std::uint32_t>(blocks_.size()));
    scanner.flush();
  }
  return sum.finish(options.min_samples, out);
}

void TileSampleBuffer::append_to(std::vector<CacheSample>* batch) const {
  batch->insert(batch->end(), samples_.begin(), samples_.end());
}

void TileSampleBuffer::clear() {
  samples_.clear();
  blocks_.clear();
}

}  // namespace dofcache::cache
