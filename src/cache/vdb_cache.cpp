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

#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include "dofcache/cache/sample_store.h"
#include "dofcache/core/error.h"
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

// Where a sample sits on a level: its leaf (origin) and voxel within the leaf. The level's arrays
// are sorted by this key, so each leaf's samples form one block and, inside it, each voxel's
// samples one run, in the leaves' own voxel order (z fastest).
struct VoxelKey {
  openvdb::Coord leaf;
  openvdb::Index offset;
  bool operator<(const VoxelKey& o) const {
    return leaf < o.leaf || (leaf == o.leaf && offset < o.offset);
  }
};

// A level's samples in the order of the level's voxels, laid out for the lookup. The distance
// prefilter reads positions and radii in blocks of eight samples (x[8], y[8], z[8], r[8]: two
// cache lines), so a voxel run's candidates are contiguous in memory; the few samples in reach
// then read one 32-byte record with what the acceptance test and the sum need.
class LevelSamples {
 public:
  static constexpr std::uint32_t kLanes = 8;

  std::size_t size() const { return records_.size(); }
  bool empty() const { return records_.empty(); }

  void reserve(std::size_t n) {
    blocks_.reserve((n + kLanes - 1) / kLanes);
    records_.reserve(n);
  }
  void push_back(const CacheSample& s) {
    push_sphere(s.position, s.radius);
    records_.push_back({s.normal, s.id, s.value, s.frame});
  }
  void append_from(const LevelSamples& o, std::size_t j) {
    push_sphere(o.position(j), o.radius(j));
    records_.push_back(o.records_[j]);
  }
  void swap(LevelSamples& o) {
    blocks_.swap(o.blocks_);
    records_.swap(o.records_);
  }

  CacheSample get(std::size_t i) const {
    CacheSample s;
    s.position = position(i);
    s.radius = radius(i);
    s.normal = records_[i].normal;
    s.id = records_[i].id;
    s.value = records_[i].value;
    s.frame = records_[i].frame;
    return s;
  }
  std::uint32_t id(std::size_t i) const { return records_[i].id; }
  glm::vec3 position(std::size_t i) const {
    const Block& b = blocks_[i / kLanes];
    return {b.x[i % kLanes], b.y[i % kLanes], b.z[i % kLanes]};
  }
  float radius(std::size_t i) const { return blocks_[i / kLanes].r[i % kLanes]; }

  std::size_t memory_bytes() const { return heap_bytes(blocks_) + heap_bytes(records_); }

  // Tests the samples [begin, end) against the query and adds the accepted ones to *sum. The
  // prefilter, ||p - p_i||^2 < r_i^2 (1 + 2^-20) computed in the order SampleTest computes it,
  // only skips samples that SampleTest::weight rejects; the decision is the scalar test's, so
  // every backend accepts the same samples with the same weights. Whole blocks are tested (lanes
  // outside the range are masked off afterwards, only when some lane passed); with AVX2 one block
  // per instruction, otherwise (SSE2, the x86-64 baseline) half a block.
  void scan(std::uint32_t begin, std::uint32_t end, const SampleTest& test,
            WeightedSum* sum) const {
#if defined(__x86_64__)
    if (kHaveAvx2) return scan_avx2(begin, end, test, sum);
#endif
#if defined(__SSE2__)
    const glm::vec3 p = test.position();
    const __m128 qx = _mm_set1_ps(p.x), qy = _mm_set1_ps(p.y), qz = _mm_set1_ps(p.z);
    const __m128 slack = _mm_set1_ps(kSlack);
    auto half = [&](const float* x, const float* y, const float* z, const float* r) {
      __m128 dx = _mm_sub_ps(qx, _mm_load_ps(x));
      __m128 dy = _mm_sub_ps(qy, _mm_load_ps(y));
      __m128 dz = _mm_sub_ps(qz, _mm_load_ps(z));
      __m128 d2 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)),
                             _mm_mul_ps(dz, dz));
      __m128 rr = _mm_load_ps(r);
      return static_cast<unsigned>(
          _mm_movemask_ps(_mm_cmplt_ps(d2, _mm_mul_ps(_mm_mul_ps(rr, rr), slack))));
    };
    for (std::uint32_t k = begin / kLanes, k_end = (end + kLanes - 1) / kLanes; k < k_end; ++k) {
      const Block& b = blocks_[k];
      unsigned mask = half(b.x, b.y, b.z, b.r) | half(b.x + 4, b.y + 4, b.z + 4, b.r + 4) << 4;
      if (mask) add_lanes(k, mask, begin, end, test, sum);
    }
#else
    for (std::uint32_t j = begin; j < end; ++j) {
      float w = test.weight(position(j), radius(j), records_[j].normal);
      if (w > 0.0f) sum->add(records_[j].id, w, records_[j].value);
    }
#endif
  }

 private:
  struct alignas(32) Block {
    float x[kLanes], y[kLanes], z[kLanes], r[kLanes];
  };
  struct Record {
    glm::vec3 normal;
    std::uint32_t id;
    glm::vec3 value;
    std::uint32_t frame;
  };
  static constexpr float kSlack = 1.0f + 0x1p-20f;
#if defined(__x86_64__)
  static inline const bool kHaveAvx2 = [] {
    __builtin_cpu_init();  // may run before libgcc's own initialisation
    return __builtin_cpu_supports("avx2") != 0;
  }();
#endif

  // Appends a sample; the unused lanes of the last block keep radius 0, out of every point's
  // reach.
  void push_sphere(glm::vec3 p, float r) {
    std::size_t i = size();
    if (i % kLanes == 0) blocks_.push_back(Block{});
    Block& b = blocks_.back();
    b.x[i % kLanes] = p.x;
    b.y[i % kLanes] = p.y;
    b.z[i % kLanes] = p.z;
    b.r[i % kLanes] = r;
  }

  // The scalar test for the lanes of block k set in mask that lie in [begin, end).
  void add_lanes(std::uint32_t k, unsigned mask, std::uint32_t begin, std::uint32_t end,
                 const SampleTest& test, WeightedSum* sum) const {
    const std::uint32_t base = k * kLanes;
    if (begin > base) mask &= ~0u << (begin - base);
    if (end - base < kLanes) mask &= (1u << (end - base)) - 1u;
    const Block& b = blocks_[k];
    while (mask) {
      auto lane = static_cast<std::uint32_t>(__builtin_ctz(mask));
      mask &= mask - 1u;
      const Record& rec = records_[base + lane];
      float w = test.weight({b.x[lane], b.y[lane], b.z[lane]}, b.r[lane], rec.normal);
      if (w > 0.0f) sum->add(rec.id, w, rec.value);
    }
  }

#if defined(__x86_64__)
  // The same with eight lanes per instruction, for processors with AVX2 (chosen at run time: not
  // in the x86-64 baseline). Still no fused multiply-add, so the arithmetic matches the SSE2 path.
  __attribute__((target("avx2"))) void scan_avx2(std::uint32_t begin, std::uint32_t end,
                                                 const SampleTest& test,
                                                 WeightedSum* sum) const {
    const glm::vec3 p = test.position();
    const __m256 qx = _mm256_set1_ps(p.x), qy = _mm256_set1_ps(p.y), qz = _mm256_set1_ps(p.z);
    const __m256 slack = _mm256_set1_ps(kSlack);
    for (std::uint32_t k = begin / kLanes, k_end = (end + kLanes - 1) / kLanes; k < k_end; ++k) {
      const Block& b = blocks_[k];
      __m256 dx = _mm256_sub_ps(qx, _mm256_load_ps(b.x));
      __m256 dy = _mm256_sub_ps(qy, _mm256_load_ps(b.y));
      __m256 dz = _mm256_sub_ps(qz, _mm256_load_ps(b.z));
      __m256 d2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)),
                                _mm256_mul_ps(dz, dz));
      __m256 rr = _mm256_load_ps(b.r);
      auto mask = static_cast<unsigned>(_mm256_movemask_ps(
          _mm256_cmp_ps(d2, _mm256_mul_ps(_mm256_mul_ps(rr, rr), slack), _CMP_LT_OQ)));
      if (mask) add_lanes(k, mask, begin, end, test, sum);
    }
  }
#endif

  std::vector<Block> blocks_;  // sample i: blocks_[i / 8], lane i % 8
  std::vector<Record> records_;
};

struct Level {
  explicit Level(int e) : exponent(e), h(std::ldexp(1.0, e)), inv_h(std::ldexp(1.0, -e)) {}

  int exponent;
  double h, inv_h;
  // Every voxel of an allocated leaf holds the index of its first sample in `samples` (empty
  // voxels too: their run is empty), so a run of voxels along z is one contiguous range, read
  // from two values of one leaf. Voxels with samples are active.
  Tree tree{0};
  LevelSamples samples;                   // sorted by VoxelKey
  std::vector<std::uint32_t> leaf_begin;  // first sample of each leaf, increasing
  float r_max = 0.0f;                     // largest radius on the level
  double reach = 0.0;                     // r_max * kRadiusPad: how far a lookup searches
  glm::dvec3 lo{0.0}, hi{0.0};            // bounds of the level's (padded) spheres
  glm::vec3 lo_f{0.0f}, hi_f{0.0f};       // the same, rounded outwards to float

  void update_float_bounds() {
    for (int a = 0; a < 3; ++a) {
      lo_f[a] = std::nextafter(static_cast<float>(lo[a]), -INFINITY);
      hi_f[a] = std::nextafter(static_cast<float>(hi[a]), INFINITY);
    }
  }

  // End of the run that stops at a leaf's last voxel: the start of the next leaf's block.
  std::uint32_t leaf_end(std::uint32_t begin) const {
    auto it = std::upper_bound(leaf_begin.begin(), leaf_begin.end(), begin);
    return it == leaf_begin.end() ? static_cast<std::uint32_t>(samples.size()) : *it;
  }
};

// floor(x) for |x| < 2^31. std::floor is a library call on baseline x86-64 (no SSE4.1 round),
// and lookups take six per level.
inline __attribute__((always_inline)) openvdb::Int32 floor_to_int(double x) {
  auto i = static_cast<openvdb::Int32>(x);  // truncates towards zero
  return i - (x < static_cast<double>(i) ? 1 : 0);
}

// The voxel of p at the level with inverse voxel size inv_h (a power of two: p * inv_h is exact).
// Callers keep |p| * inv_h below 2^28 (samples by their level choice, queries by the level's
// bounds test).
inline __attribute__((always_inline)) openvdb::Coord voxel_of(glm::dvec3 p, double inv_h) {
  return openvdb::Coord(floor_to_int(p.x * inv_h), floor_to_int(p.y * inv_h),
                        floor_to_int(p.z * inv_h));
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
    const Reader& reader = this->reader();
    const SampleTest test(p, n, options);
    const glm::dvec3 q(p);
    for (std::size_t k = 0; k < active_.size(); ++k) {
      const Bounds& bounds = bounds_[k];
      if (p.x < bounds.lo.x || p.y < bounds.lo.y || p.z < bounds.lo.z || p.x > bounds.hi.x ||
          p.y > bounds.hi.y || p.z > bounds.hi.z)
        continue;
      const Level& level = *active_[k];
      // The voxels the ball of the level's largest radius around q touches: any sample that can
      // accept q has its centre, hence its voxel, inside that ball. With cell_scale >= 2 the box
      // spans at most 2 voxels per axis, so it usually lies in one leaf: probe each leaf it
      // touches once, then read the runs along z straight from the leaf's start indices.
      const openvdb::Coord a = voxel_of(q - level.reach, level.inv_h);
      const openvdb::Coord b = voxel_of(q + level.reach, level.inv_h);
      const ConstAccessor& acc = reader.accessors[k];
      constexpr openvdb::Int32 kMask = LeafT::DIM - 1;
      for (openvdb::Int32 lx = a.x() & ~kMask; lx <= b.x(); lx += LeafT::DIM)
        for (openvdb::Int32 ly = a.y() & ~kMask; ly <= b.y(); ly += LeafT::DIM)
          for (openvdb::Int32 lz = a.z() & ~kMask; lz <= b.z(); lz += LeafT::DIM) {
            const LeafT* leaf = acc.probeConstLeaf(openvdb::Coord(lx, ly, lz));
            if (!leaf) continue;
            const openvdb::Int32* start = leaf->buffer().data();
            const openvdb::Int32 x0 = std::max(a.x(), lx) & kMask,
                                 x1 = std::min(b.x(), lx + kMask) & kMask;
            const openvdb::Int32 y0 = std::max(a.y(), ly) & kMask,
                                 y1 = std::min(b.y(), ly + kMask) & kMask;
            const openvdb::Int32 z0 = std::max(a.z(), lz) & kMask,
                                 z1 = std::min(b.z(), lz + kMask) & kMask;
            for (openvdb::Int32 x = x0; x <= x1; ++x)
              for (openvdb::Int32 y = y0; y <= y1; ++y) {
                // The run of voxels (x, y, z0..z1): samples [start[first], start[last + 1]).
                const auto first = static_cast<openvdb::Index>(
                    (x << (2 * LeafT::LOG2DIM)) | (y << LeafT::LOG2DIM) | z0);
                const openvdb::Index last = first + static_cast<openvdb::Index>(z1 - z0);
                const auto begin = static_cast<std::uint32_t>(start[first]);
                const auto end = last + 1 < LeafT::SIZE
                                     ? static_cast<std::uint32_t>(start[last + 1])
                                     : level.leaf_end(static_cast<std::uint32_t>(start[0]));
                if (begin < end) level.samples.scan(begin, end, test, &sum);
              }
          }
    }
    return sum.finish(options.min_samples, out);
  }

  std::size_t size() const override {
    std::size_t n = 0;
    for (const Level* level : active_) n += level->samples.size();
    return n;
  }

  std::size_t memory_bytes() const override {
    std::size_t bytes = heap_bytes(active_) + heap_bytes(bounds_);
    for (const Level* level : active_)
      bytes += sizeof(Level) + static_cast<std::size_t>(level->tree.memUsage()) +
               heap_bytes(level->leaf_begin) + level->samples.memory_bytes();
    return bytes;
  }

  void for_each_sample(const std::function<void(const CacheSample&)>& fn) const override {
    struct Ref {
      std::uint32_t id, level, index;
    };
    std::vector<Ref> refs;
    refs.reserve(size());
    for (std::size_t k = 0; k < active_.size(); ++k)
      for (std::size_t i = 0; i < active_[k]->samples.size(); ++i)
        refs.push_back({active_[k]->samples.id(i), static_cast<std::uint32_t>(k),
                        static_cast<std::uint32_t>(i)});
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

  // Adds samples[indices] to the level: merges them, sorted by VoxelKey, with the level's sorted
  // arrays and rewrites the start indices of every leaf. One pass over the level (between render
  // passes, so bandwidth, not latency, bound).
  static void merge_into(Level& level, const std::vector<CacheSample>& samples,
                         const std::vector<std::uint32_t>& indices) {
    auto key_of = [&](glm::vec3 p) {
      openvdb::Coord c = voxel_of(glm::dvec3(p), level.inv_h);
      return VoxelKey{c & ~(LeafT::DIM - 1), LeafT::coordToOffset(c)};
    };
    std::vector<std::pair<VoxelKey, std::uint32_t>> added;  // (key, index into samples)
    added.reserve(indices.size());
    for (std::uint32_t i : indices) {
      const CacheSample& s = samples[i];
      added.push_back({key_of(s.position), i});
      level.r_max = std::max(level.r_max, s.radius);
      level.reach = level.r_max * kRadiusPad;
      glm::dvec3 p(s.position);
      double r = s.radius * kRadiusPad;
      bool first = level.samples.empty() && added.size() == 1;
      level.lo = first ? p - r : glm::min(level.lo, p - r);
      level.hi = first ? p + r : glm::max(level.hi, p + r);
    }
    level.update_float_bounds();
    std::stable_sort(added.begin(), added.end(),
                     [](const auto& x, const auto& y) { return x.first < y.first; });

    // Merge, and note each sample's key for the start indices below.
    LevelSamples merged;
    merged.reserve(level.samples.size() + added.size());
    std::vector<VoxelKey> keys;
    keys.reserve(level.samples.size() + added.size());
    std::size_t old = 0, next = 0;
    VoxelKey old_key{};
    if (old < level.samples.size()) old_key = key_of(level.samples.position(old));
    while (old < level.samples.size() || next < added.size()) {
      bool take_new = old == level.samples.size() ||
                      (next < added.size() && added[next].first < old_key);
      if (take_new) {
        merged.push_back(samples[added[next].second]);
        keys.push_back(added[next].first);
        ++next;
      } else {
        merged.append_from(level.samples, old);
        keys.push_back(old_key);
        if (++old < level.samples.size()) old_key = key_of(level.samples.position(old));
      }
    }
    level.samples.swap(merged);

    // Start indices: for each leaf, a running count over its 512 voxels.
    openvdb::tree::ValueAccessor<Tree> acc(level.tree);
    level.leaf_begin.clear();
    for (std::size_t i = 0; i < keys.size();) {
      std::size_t end = i;
      while (end < keys.size() && keys[end].leaf == keys[i].leaf) ++end;
      LeafT* leaf = acc.touchLeaf(keys[i].leaf);
      level.leaf_begin.push_back(static_cast<std::uint32_t>(i));
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
        active_.push_back(levels_[k].get());
        bounds_.push_back({levels_[k]->lo_f, levels_[k]->hi_f});
      }
    epoch_ = ++g_epoch;
  }

  float cell_scale_ = 4.0f;
  std::array<std::unique_ptr<Level>, kLevelCount> levels_;
  std::uint64_t mask_ = 0;      // bit k: level kMinExponent + k holds samples
  std::vector<Level*> active_;  // the non-empty levels, finest first
  struct Bounds {
    glm::vec3 lo, hi;
  };
  std::vector<Bounds> bounds_;  // their float bounds, packed for the lookup's first test
  std::uint64_t epoch_;
};

}  // namespace

std::unique_ptr<RadianceCache> make_vdb_radiance_cache(const VdbCacheOptions& options) {
  return std::make_unique<VdbRadianceCache>(options);
}

}  // namespace dofcache::cache
