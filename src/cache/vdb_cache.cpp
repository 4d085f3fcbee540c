// The only translation unit that includes OpenVDB (BUILD-NOTES: it dominates build time).
#include "dofcache/cache/vdb_cache.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cassert>
#include <cmath>

#include <glm/common.hpp>
#include <openvdb/openvdb.h>
#include <openvdb/tree/ValueAccessor.h>

#if defined(__SSE2__)
#include <immintrin.h>
#endif

#include "dofcache/core/error.h"
#include "dofcache/cache/sample_blocks.h"
#include "grid_math.h"

namespace dofcache::cache {
namespace {

using Tree = openvdb::Int32Tree;  // voxel -> index of its first sample on the level
using LeafT = Tree::LeafNodeType;
using ConstAccessor = openvdb::tree::ValueAccessor<const Tree, /*IsSafe=*/false>;

// Levels e = kMinExponent .. kMinExponent + 63 (voxels from 2^-40 m to 2^23 m): one mask bit each.
constexpr int kMinExponent = -40;
constexpr int kLevelCount = 64;
// Samples are filed at a level coarse enough that their voxel coordinates stay below 2^27 in
// magnitude, far inside OpenVDB's 32-bit index space. A query reaches a level only inside the
// bounds of its samples' spheres, so its voxel coordinates are in range too.
constexpr int kCoordBits = 27;

// Where a copy sits on a level: its leaf (origin) and voxel within the leaf. The level's arrays
// are sorted by this key, so each leaf's copies form one block and, inside it, each voxel's
// copies one run, in the leaves' own voxel order (z fastest).
struct VoxelKey {
  openvdb::Coord leaf;
  openvdb::Index offset;

  static VoxelKey of(const openvdb::Coord& voxel) {
    return {voxel & ~(LeafT::DIM - 1), LeafT::coordToOffset(voxel)};
  }
  bool operator==(const VoxelKey& o) const { return leaf == o.leaf && offset == o.offset; }
  bool operator<(const VoxelKey& o) const {
    return leaf < o.leaf || (leaf == o.leaf && offset < o.offset);
  }
};

struct Level {
  explicit Level(int e) : exponent(e), h(std::ldexp(1.0, e)), inv_h(std::ldexp(1.0, -e)) {}

  int exponent;
  double h, inv_h;
  // Every voxel of an allocated leaf holds the index of its first copy in `samples` (empty
  // voxels too: their run is empty), so a voxel's copies are one contiguous range, read from two
  // values of one leaf. Voxels with copies are active.
  Tree tree{0};
  BlockSamples samples;                   // copies, sorted by VoxelKey
  std::vector<std::uint32_t> leaf_begin;  // first copy of each leaf, increasing
  std::vector<openvdb::Coord> leaf_origin;  // origin of each leaf, in the same order
  std::size_t homes = 0;                  // samples (each has one home copy)
  glm::dvec3 lo{0.0}, hi{0.0};            // bounds of the level's (padded) spheres
  glm::vec3 lo_f{0.0f}, hi_f{0.0f};       // the same, rounded outwards to float

  void update_float_bounds() {
    for (int a = 0; a < 3; ++a) {
      lo_f[a] = std::nextafter(static_cast<float>(lo[a]), -INFINITY);
      hi_f[a] = std::nextafter(static_cast<float>(hi[a]), INFINITY);
    }
  }

  // End of the run of a leaf's last voxel: the start of the next leaf's block.
  std::uint32_t leaf_end(std::uint32_t begin) const {
    auto it = std::upper_bound(leaf_begin.begin(), leaf_begin.end(), begin);
    return it == leaf_begin.end() ? static_cast<std::uint32_t>(samples.size()) : *it;
  }

  // The copies of the voxel at `offset` in `leaf`: [begin, end).
  void voxel_run(const LeafT& leaf, openvdb::Index offset, std::uint32_t* begin,
                 std::uint32_t* end) const {
    const openvdb::Int32* start = leaf.buffer().data();
    *begin = static_cast<std::uint32_t>(start[offset]);
    *end = offset + 1 < LeafT::SIZE ? static_cast<std::uint32_t>(start[offset + 1])
                                    : leaf_end(static_cast<std::uint32_t>(start[0]));
  }

  // Calls fn(key, copy) for every copy in storage order, with the key of the voxel it is filed in.
  template <typename Fn>
  void for_each_copy(Fn&& fn) const {
    openvdb::tree::ValueAccessor<const Tree> acc(tree);
    for (std::size_t l = 0; l < leaf_origin.size(); ++l) {
      const LeafT& leaf = *acc.probeConstLeaf(leaf_origin[l]);
      for (openvdb::Index offset = 0; offset < LeafT::SIZE; ++offset) {
        std::uint32_t begin, end;
        voxel_run(leaf, offset, &begin, &end);
        for (std::uint32_t i = begin; i < end; ++i) fn(VoxelKey{leaf_origin[l], offset}, i);
      }
    }
  }
};

// floor(x) for |x| < 2^31. std::floor is a library call on baseline x86-64 (no SSE4.1 round),
// and lookups take six per level.
inline __attribute__((always_inline)) openvdb::Int32 floor_to_int(double x) {
  auto i = static_cast<openvdb::Int32>(x);  // truncates towards zero
  return i - (x < static_cast<double>(i) ? 1 : 0);
}

// Voxel v of a level covers [(v - 1/2) h, (v + 1/2) h): the multiples of h are voxel centres.
// Surfaces at round coordinates (a floor at y = 0, walls at whole metres) thus lie mid-voxel on
// the fine levels. On voxel boundaries, which include leaf boundaries, every lookup on them would
// read the voxels and probe the leaves on both sides.
constexpr double kVoxelShift = 0.5;

// The voxel of p at the level with inverse voxel size inv_h (a power of two: p * inv_h is exact;
// adding 1/2 may round, by less than the radius padding allows for). Callers keep |p| * inv_h
// below 2^28 (samples by their level choice, queries by the level's bounds test).
inline __attribute__((always_inline)) openvdb::Coord voxel_of(glm::dvec3 p, double inv_h) {
  return openvdb::Coord(floor_to_int(p.x * inv_h + kVoxelShift),
                        floor_to_int(p.y * inv_h + kVoxelShift),
                        floor_to_int(p.z * inv_h + kVoxelShift));
}

// Every mutation of any cache takes a fresh, globally unique epoch; a thread's cached accessors
// are valid while their epoch matches the cache's.
std::atomic<std::uint64_t> g_epoch{0};

// Per-thread OpenVDB accessors, one per non-empty level of a cache the thread reads. Coherent
// lookups (the lens rays of a pixel, the pixels of a tile) then hit the accessors' cached leaf and
// skip the root-to-leaf descent. Unregistered (IsSafe = false) accessors of a const tree: no
// locking, and nothing touches the tree when they are dropped. A thread keeps readers for the last
// few caches it used, so alternating between two caches does not rebuild them every time.
struct Reader {
  std::uint64_t epoch = 0;
  std::vector<ConstAccessor> accessors;
};
struct Readers {
  std::array<Reader, 4> slots;
  unsigned next = 0;
};
thread_local Readers t_readers;

class VdbRadianceCache final : public RadianceCache {
 public:
  explicit VdbRadianceCache(const VdbCacheOptions& options) : epoch_(++g_epoch) {
    float s = options.cell_scale;
    if (!(s >= 1.0f && s <= 8.0f) || std::exp2(std::round(std::log2(s))) != s)
      throw Error("vdb cache: cell_scale must be 1, 2, 4 or 8, got " + std::to_string(s));
    cell_scale_ = s;
    openvdb::initialize();
  }

  std::string name() const override { return "vdb"; }

  bool lookup(glm::vec3 p, glm::vec3 n, const LookupOptions& options,
              LookupResult* out) const override {
    WeightedSum sum;
    const SampleTest test(p, n, options);
    if (std::uint64_t in = levels_containing(p)) {
      const Reader& reader = this->reader();
      // One run per level: the copies filed in p's voxel.
      RangeScanner scanner(test, &sum);
      const glm::dvec3 q(p);
      do {
        const auto k = static_cast<unsigned>(__builtin_ctzll(in));
        in &= in - 1;
        const Level& level = *active_[k];
        const openvdb::Coord c = voxel_of(q, level.inv_h);
        if (const LeafT* leaf = reader.accessors[k].probeConstLeaf(c)) {
          std::uint32_t begin, end;
          level.voxel_run(*leaf, LeafT::coordToOffset(c), &begin, &end);
          if (begin < end) scanner.add(&level.samples, begin, end);
        }
      } while (in);
      scanner.flush();
    }
    return sum.finish(options.min_samples, out);
  }

  std::size_t size() const override {
    std::size_t n = 0;
    for (const Level* level : active_) n += level->homes;
    return n;
  }

  std::size_t memory_bytes() const override {
    std::size_t bytes = heap_bytes(active_) + heap_bytes(bounds_);
    for (const Level* level : active_)
      bytes += sizeof(Level) + static_cast<std::size_t>(level->tree.memUsage()) +
               heap_bytes(level->leaf_begin) + heap_bytes(level->leaf_origin) +
               level->samples.memory_bytes();
    return bytes;
  }

  void for_each_sample(const std::function<void(const CacheSample&)>& fn) const override {
    struct Ref {
      std::uint32_t id, level, index;
    };
    std::vector<Ref> refs;
    refs.reserve(size());
    for (std::size_t k = 0; k < active_.size(); ++k) {
      const Level& level = *active_[k];
      level.for_each_copy([&](const VoxelKey& key, std::uint32_t i) {
        if (is_home(level, key, i))
          refs.push_back({level.samples.id(i), static_cast<std::uint32_t>(k), i});
      });
    }
    std::sort(refs.begin(), refs.end(), [](const Ref& x, const Ref& y) { return x.id < y.id; });
    for (const Ref& r : refs) fn(active_[r.level]->samples.get(r.index));
  }

 protected:
  void add_samples(const std::vector<CacheSample>& samples) override {
    // Group by level, then merge each touched level once.
    std::array<std::vector<std::uint32_t>, kLevelCount> by_level;
    for (std::uint32_t i = 0; i < samples.size(); ++i)
      by_level[level_index(samples[i])].push_back(i);
    for (int k = 0; k < kLevelCount; ++k) {
      if (by_level[k].empty()) continue;
      if (!levels_[k]) levels_[k] = std::make_unique<Level>(kMinExponent + k);
      merge_into(*levels_[k], samples, by_level[k]);
      mask_ |= std::uint64_t{1} << k;
    }
    rebuild_active();
  }

  void remove_all() override {
    for (auto& level : levels_) level.reset();
    mask_ = 0;
    rebuild_active();
    active_.shrink_to_fit();
    bounds_.shrink_to_fit();
  }

 private:
  // Bounds of four active levels (k = 4g .. 4g + 3) by axis, for the lookup's first test; unused
  // lanes hold an empty box.
  struct BoundsGroup {
    alignas(16) float lo[3][4];
    alignas(16) float hi[3][4];
  };

  // Bit k: p lies within the bounds of active level k, the only levels that can hold a sample
  // accepting p. Four levels per comparison.
  std::uint64_t levels_containing(glm::vec3 p) const {
    std::uint64_t in = 0;
#if defined(__SSE2__)
    const __m128 x = _mm_set1_ps(p.x), y = _mm_set1_ps(p.y), z = _mm_set1_ps(p.z);
    for (std::size_t g = 0; g < bounds_.size(); ++g) {
      const BoundsGroup& b = bounds_[g];
      const __m128 below = _mm_or_ps(_mm_or_ps(_mm_cmplt_ps(x, _mm_load_ps(b.lo[0])),
                                               _mm_cmplt_ps(y, _mm_load_ps(b.lo[1]))),
                                     _mm_cmplt_ps(z, _mm_load_ps(b.lo[2])));
      const __m128 above = _mm_or_ps(_mm_or_ps(_mm_cmpgt_ps(x, _mm_load_ps(b.hi[0])),
                                               _mm_cmpgt_ps(y, _mm_load_ps(b.hi[1]))),
                                     _mm_cmpgt_ps(z, _mm_load_ps(b.hi[2])));
      const auto outside = static_cast<unsigned>(_mm_movemask_ps(_mm_or_ps(below, above)));
      in |= static_cast<std::uint64_t>(~outside & 0xFu) << (4 * g);
    }
#else
    for (std::size_t k = 0; k < active_.size(); ++k) {
      const BoundsGroup& b = bounds_[k / 4];
      const std::size_t l = k % 4;
      if (!(p.x < b.lo[0][l] || p.y < b.lo[1][l] || p.z < b.lo[2][l] || p.x > b.hi[0][l] ||
            p.y > b.hi[1][l] || p.z > b.hi[2][l]))
        in |= std::uint64_t{1} << k;
    }
#endif
    // A NaN coordinate compares false everywhere: keep the unused lanes out.
    return active_.size() < 64 ? in & ((std::uint64_t{1} << active_.size()) - 1) : in;
  }

  // Whether copy i, filed under key, is its sample's home copy: the one in the voxel of its
  // centre.
  static bool is_home(const Level& level, const VoxelKey& key, std::uint32_t i) {
    return VoxelKey::of(voxel_of(glm::dvec3(level.samples.position(i)), level.inv_h)) == key;
  }

  const Reader& reader() const {
    Readers& readers = t_readers;
    for (const Reader& r : readers.slots)
      if (r.epoch == epoch_) return r;
    Reader& r = readers.slots[readers.next++ % readers.slots.size()];
    r.accessors.clear();
    for (const Level* level : active_) r.accessors.emplace_back(level->tree);
    r.epoch = epoch_;
    return r;
  }

  // The level whose voxels are at least cell_scale times the radius, and coarse enough to keep
  // the sample's voxel coordinates small.
  int level_index(const CacheSample& s) const {
    int e = ceil_log2(static_cast<double>(cell_scale_) * s.radius);
    double extent = std::max({std::abs(s.position.x), std::abs(s.position.y),
                              std::abs(s.position.z)});
    if (extent > 0.0) e = std::max(e, ceil_log2(extent) - kCoordBits);
    assert(e < kMinExponent + kLevelCount && "sample radius beyond 2^23 m");
    return std::clamp(e - kMinExponent, 0, kLevelCount - 1);
  }

  // Adds samples[indices] to the level: a copy of each in every voxel its padded sphere's box
  // touches, merged, sorted by VoxelKey, with the level's sorted copies; then rewrites the start
  // indices of every leaf. One pass over the level (between render passes, so bandwidth, not
  // latency, bound).
  static void merge_into(Level& level, const std::vector<CacheSample>& samples,
                         const std::vector<std::uint32_t>& indices) {
    std::vector<std::pair<VoxelKey, std::uint32_t>> added;  // (key, index into samples)
    added.reserve(indices.size() * 4);
    for (std::uint32_t i : indices) {
      const CacheSample& s = samples[i];
      const glm::dvec3 p(s.position);
      const double r = s.radius * kRadiusPad;
      const openvdb::Coord a = voxel_of(p - r, level.inv_h), b = voxel_of(p + r, level.inv_h);
      for (openvdb::Int32 x = a.x(); x <= b.x(); ++x)
        for (openvdb::Int32 y = a.y(); y <= b.y(); ++y)
          for (openvdb::Int32 z = a.z(); z <= b.z(); ++z) {
            added.push_back({VoxelKey::of(openvdb::Coord(x, y, z)), i});
          }
      const bool first = level.homes == 0;
      ++level.homes;
      level.lo = first ? p - r : glm::min(level.lo, p - r);
      level.hi = first ? p + r : glm::max(level.hi, p + r);
    }
    level.update_float_bounds();
    std::stable_sort(added.begin(), added.end(),
                     [](const auto& x, const auto& y) { return x.first < y.first; });

    // The existing copies' keys, in storage order (sorted).
    std::vector<VoxelKey> old_keys;
    old_keys.reserve(level.samples.size());
    level.for_each_copy([&](const VoxelKey& key, std::uint32_t) { old_keys.push_back(key); });

    // Merge (a voxel's existing copies first), and note each copy's key for the start indices.
    BlockSamples merged;
    merged.reserve(old_keys.size() + added.size());
    std::vector<VoxelKey> keys;
    keys.reserve(old_keys.size() + added.size());
    std::size_t old = 0, next = 0;
    while (old < old_keys.size() || next < added.size()) {
      if (old == old_keys.size() || (next < added.size() && added[next].first < old_keys[old])) {
        merged.push_back(samples[added[next].second]);
        keys.push_back(added[next].first);
        ++next;
      } else {
        merged.append_from(level.samples, old);
        keys.push_back(old_keys[old]);
        ++old;
      }
    }
    level.samples.swap(merged);

    // Start indices: for each leaf, a running count over its 512 voxels.
    openvdb::tree::ValueAccessor<Tree> acc(level.tree);
    level.leaf_begin.clear();
    level.leaf_origin.clear();
    for (std::size_t i = 0; i < keys.size();) {
      std::size_t end = i;
      while (end < keys.size() && keys[end].leaf == keys[i].leaf) ++end;
      LeafT* leaf = acc.touchLeaf(keys[i].leaf);
      level.leaf_begin.push_back(static_cast<std::uint32_t>(i));
      level.leaf_origin.push_back(keys[i].leaf);
      std::size_t j = i;
      for (openvdb::Index offset = 0; offset < LeafT::SIZE; ++offset) {
        leaf->setValueOnly(offset, static_cast<openvdb::Int32>(j));
        bool occupied = j < end && keys[j].offset == offset;
        while (j < end && keys[j].offset == offset) ++j;
        if (occupied) leaf->setValueOn(offset);
      }
      i = end;
    }
  }

  void rebuild_active() {
    active_.clear();
    bounds_.clear();
    for (int k = 0; k < kLevelCount; ++k)
      if (mask_ >> k & 1) {
        const std::size_t i = active_.size();
        active_.push_back(levels_[k].get());
        if (i % 4 == 0) {
          BoundsGroup empty;
          for (int a = 0; a < 3; ++a)
            for (int l = 0; l < 4; ++l) {
              empty.lo[a][l] = INFINITY;
              empty.hi[a][l] = -INFINITY;
            }
          bounds_.push_back(empty);
        }
        for (int a = 0; a < 3; ++a) {
          bounds_.back().lo[a][i % 4] = levels_[k]->lo_f[a];
          bounds_.back().hi[a][i % 4] = levels_[k]->hi_f[a];
        }
      }
    epoch_ = ++g_epoch;
  }

  float cell_scale_ = 4.0f;
  std::array<std::unique_ptr<Level>, kLevelCount> levels_;
  std::uint64_t mask_ = 0;      // bit k: level kMinExponent + k holds samples
  std::vector<Level*> active_;       // the non-empty levels, finest first
  std::vector<BoundsGroup> bounds_;  // their float bounds, packed for the lookup's first test
  std::uint64_t epoch_;
};

}  // namespace

std::unique_ptr<RadianceCache> make_vdb_radiance_cache(const VdbCacheOptions& options) {
  return std::make_unique<VdbRadianceCache>(options);
}

}  // namespace dofcache::cache
