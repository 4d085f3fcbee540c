#pragma once
// The radiance cache interface (paper section 4, Algorithm 1) and the factory that picks a
// backend by name.
//
// Determinism: during a render pass the cache is read only (lookup may be called from any number
// of threads); samples created in the pass go to per-tile TileSampleBuffers and are merged with
// insert() between passes, single-threaded. insert() sorts each batch into a canonical order
// before assigning ids, and lookups sum in id order, so results depend neither on the thread
// count nor on the order in which tiles hand in their samples, nor on the backend.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "dofcache/cache/sample.h"

namespace dofcache::cache {

class RadianceCache {
 public:
  virtual ~RadianceCache() = default;

  // "octree" or "vdb".
  virtual std::string name() const = 0;

  // Interpolates the cached value at p (unit normal n) from every sample that passes the tests of
  // weights.h. Returns true when at least options.min_samples samples were accepted; *out (may be
  // null) is filled either way. Safe for concurrent callers while no insert, restore, erase_if or
  // clear runs.
  virtual bool lookup(glm::vec3 p, glm::vec3 n, const LookupOptions& options,
                      LookupResult* out) const = 0;

  // Adds a batch: sorts it canonically (by position, then every other field), assigns consecutive
  // ids from next_id() and stores it. The ids in the batch are ignored. Single-threaded.
  void insert(const std::vector<CacheSample>& batch);

  // Adds samples keeping their ids (loading a saved cache, eviction): ids must be unique and not
  // already in the cache. next_id() moves past the largest.
  void restore(const std::vector<CacheSample>& samples);

  // Removes the samples for which pred is true (eviction); the others keep their ids. Returns the
  // number removed.
  std::size_t erase_if(const std::function<bool(const CacheSample&)>& pred);

  // Removes every sample and restarts ids at 0.
  void clear();

  virtual std::size_t size() const = 0;

  // Bytes of every allocation the cache holds (vector capacities with the allocator's chunk
  // overhead, OpenVDB tree nodes), not counting the object itself.
  virtual std::size_t memory_bytes() const = 0;

  // Visits every sample in increasing id.
  virtual void for_each_sample(const std::function<void(const CacheSample&)>& fn) const = 0;

  std::vector<CacheSample> samples() const;  // every sample, in increasing id
  std::uint32_t next_id() const { return next_id_; }

 protected:
  // Stores samples whose ids are already assigned (in any order).
  virtual void add_samples(const std::vector<CacheSample>& samples) = 0;
  virtual void remove_all() = 0;

 private:
  std::uint32_t next_id_ = 0;
};

// The backends' names: no cache, and the backend chosen where a cache is wanted and none is named
// (measured at least as fast as the octree, docs/cache.md).
constexpr const char* kNoCache = "none";
constexpr const char* kDefaultCacheBackend = "vdb";

// The names make_radiance_cache accepts, "none" included: {"none", "octree", "vdb"}.
const std::vector<std::string>& radiance_cache_backends();

// The one check of a backend name, for everything that takes one (render, sequence, persistent
// cache, farm plan): throws dofcache::Error "unknown cache backend '<name>' (valid: ...)" unless
// `name` is one of radiance_cache_backends(); "none" (no cache) counts only if `allow_none`.
void check_radiance_cache_backend(const std::string& name, bool allow_none);

// "octree" or "vdb" (default options); "none" returns nullptr (the renderer then shades every
// hit). Anything else throws dofcache::Error listing the valid names.
std::unique_ptr<RadianceCache> make_radiance_cache(const std::string& backend);

// Sorts samples into the canonical order insert() uses: Morton order of the position's bit
// patterns (spatially coherent storage), ties broken by every field's bit pattern.
void sort_canonically(std::vector<CacheSample>* samples);

}  // namespace dofcache::cache
