#include "dofcache/cache/radiance_cache.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cassert>
#include <cstring>
#include <tuple>

#include "dofcache/cache/octree_cache.h"
#include "dofcache/cache/vdb_cache.h"
#include "dofcache/core/error.h"

namespace dofcache::cache {
namespace {

std::uint32_t bits(float f) {
  std::uint32_t u;
  std::memcpy(&u, &f, sizeof u);
  return u;
}

// Order-preserving map of a float's bits to an unsigned integer (negative values flipped).
std::uint32_t ordered_bits(float f) {
  std::uint32_t u = bits(f);
  return (u & 0x80000000u) ? ~u : (u | 0x80000000u);
}

// Spreads the low 21 bits of x to every third bit.
std::uint64_t spread3(std::uint64_t x) {
  x &= 0x1fffff;
  x = (x | x << 32) & 0x1f00000000ffffULL;
  x = (x | x << 16) & 0x1f0000ff0000ffULL;
  x = (x | x << 8) & 0x100f00f00f00f00fULL;
  x = (x | x << 4) & 0x10c30c30c30c30c3ULL;
  x = (x | x << 2) & 0x1249249249249249ULL;
  return x;
}

struct CanonicalKey {
  std::uint64_t morton;
  std::array<std::uint32_t, 11> fields;
  bool operator<(const CanonicalKey& o) const {
    return std::tie(morton, fields) < std::tie(o.morton, o.fields);
  }
};

CanonicalKey canonical_key(const CacheSample& s) {
  CanonicalKey k;
  k.morton = spread3(ordered_bits(s.position.x) >> 11) << 2 |
             spread3(ordered_bits(s.position.y) >> 11) << 1 |
             spread3(ordered_bits(s.position.z) >> 11);
  k.fields = {bits(s.position.x), bits(s.position.y), bits(s.position.z), bits(s.normal.x),
              bits(s.normal.y),   bits(s.normal.z),   bits(s.radius),     bits(s.value.x),
              bits(s.value.y),    bits(s.value.z),    s.frame};
  return k;
}

}  // namespace

void sort_canonically(std::vector<CacheSample>* samples) {
  std::vector<std::pair<CanonicalKey, std::uint32_t>> keys(samples->size());
  for (std::size_t i = 0; i < samples->size(); ++i)
    keys[i] = {canonical_key((*samples)[i]), static_cast<std::uint32_t>(i)};
  std::sort(keys.begin(), keys.end());
  std::vector<CacheSample> sorted(samples->size());
  for (std::size_t i = 0; i < keys.size(); ++i) sorted[i] = (*samples)[keys[i].second];
  samples->swap(sorted);
}

void RadianceCache::insert(const std::vector<CacheSample>& batch) {
  if (batch.empty()) return;
  std::vector<CacheSample> sorted = batch;
  sort_canonically(&sorted);
  for (CacheSample& s : sorted) {
    assert(s.radius > 0.0f && std::isfinite(s.radius));
    s.id = next_id_++;
  }
  add_samples(sorted);
}

void RadianceCache::restore(const std::vector<CacheSample>& samples) {
  if (samples.empty()) return;
  std::uint32_t max_id = 0;
  for (const CacheSample& s : samples) max_id = std::max(max_id, s.id);
  add_samples(samples);
  next_id_ = std::max(next_id_, max_id + 1);
}

std::size_t RadianceCache::erase_if(const std::function<bool(const CacheSample&)>& pred) {
  std::vector<CacheSample> keep;
  std::size_t removed = 0;
  for_each_sample([&](const CacheSample& s) {
    if (pred(s))
      ++removed;
    else
      keep.push_back(s);
  });
  if (removed == 0) return 0;
  remove_all();
  add_samples(keep);  // ids and next_id() unchanged
  return removed;
}

void RadianceCache::clear() {
  remove_all();
  next_id_ = 0;
}

std::vector<CacheSample> RadianceCache::samples() const {
  std::vector<CacheSample> out;
  out.reserve(size());
  for_each_sample([&](const CacheSample& s) { out.push_back(s); });
  return out;
}

const std::vector<std::string>& radiance_cache_backends() {
  static const std::vector<std::string> names = {"none", "octree", "vdb"};
  return names;
}

void check_radiance_cache_backend(const std::string& name, bool allow_none) {
  const std::vector<std::string>& names = radiance_cache_backends();
  if (std::find(names.begin(), names.end(), name) != names.end() && (allow_none || name != "none"))
    return;
  std::string valid;
  for (const std::string& n : names)
    if (allow_none || n != "none") valid += (valid.empty() ? "" : ", ") + n;
  throw Error("unknown cache backend '" + name + "' (valid: " + valid + ")");
}

std::unique_ptr<RadianceCache> make_radiance_cache(const std::string& backend) {
  check_radiance_cache_backend(backend, /*allow_none=*/true);
  if (backend == "octree") return make_octree_radiance_cache();
  if (backend == "vdb") return make_vdb_radiance_cache();
  return nullptr;  // "none"
}

}  // namespace dofcache::cache
