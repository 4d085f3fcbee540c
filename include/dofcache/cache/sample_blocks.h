#pragma once
// Cache samples laid out for lookups, and the one lookup kernel over them: samples in blocks of
// eight for a SIMD distance prefilter, then the scalar SampleTest for the few in reach. Both
// radiance-cache backends and the tile buffer use them, so octree and vdb are compared as
// structures with the same sample layout and the same tests.
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include <glm/vec3.hpp>

#include "dofcache/cache/sample.h"
#include "dofcache/cache/weights.h"

namespace dofcache::cache {

// Bytes a vector's buffer occupies on the heap: its capacity plus the allocator's chunk header
// and rounding (glibc: 8-byte header, 16-byte granularity, 32-byte minimum).
template <typename T>
std::size_t heap_bytes(const std::vector<T>& v) {
  if (v.capacity() == 0) return 0;
  std::size_t n = v.capacity() * sizeof(T) + 8;
  n = (n + 15) & ~std::size_t{15};
  return n < 32 ? 32 : n;
}

// The distance prefilter's bound is r^2 kSlack, a hair above the test's r^2 (scan_ranges_baseline).
constexpr float kSlack = 1.0f + 0x1p-20f;

// Samples laid out for the lookup, in the order of the structure that indexes them (a vdb level's
// voxels, the octree's nodes). The distance
// prefilter reads positions and bounds in blocks of eight samples (x[8], y[8], z[8], reach2[8]:
// two cache lines), so a voxel run's candidates are contiguous in memory; radii and normals follow
// (the next two lines) for the scalar test of the few in reach, and the accepted ones read a
// 16-byte record (id, value). Frames are only read back (get), so they sit apart.
class BlockSamples {
 public:
  static constexpr std::uint32_t kLanes = 8;
  struct alignas(32) Block {
    float x[kLanes], y[kLanes], z[kLanes], reach2[kLanes];  // reach2 = r^2 (1 + 2^-20)
    float r[kLanes], nx[kLanes], ny[kLanes], nz[kLanes];
  };
  struct Record {
    std::uint32_t id;
    glm::vec3 value;
  };

  std::size_t size() const { return records_.size(); }
  bool empty() const { return records_.empty(); }

  void clear() {  // keeps the buffers
    blocks_.clear();
    records_.clear();
    frames_.clear();
  }
  void reserve(std::size_t n) {
    blocks_.reserve((n + kLanes - 1) / kLanes);
    records_.reserve(n);
    frames_.reserve(n);
  }
  void push_back(const CacheSample& s) {
    push_geometry(s.position, s.radius, s.normal);
    records_.push_back({s.id, s.value});
    frames_.push_back(s.frame);
  }
  void append_from(const BlockSamples& o, std::size_t j) {
    push_geometry(o.position(j), o.radius(j), o.normal(j));
    records_.push_back(o.records_[j]);
    frames_.push_back(o.frames_[j]);
  }
  void swap(BlockSamples& o) {
    blocks_.swap(o.blocks_);
    records_.swap(o.records_);
    frames_.swap(o.frames_);
  }

  CacheSample get(std::size_t i) const {
    CacheSample s;
    s.position = position(i);
    s.radius = radius(i);
    s.normal = normal(i);
    s.id = records_[i].id;
    s.value = records_[i].value;
    s.frame = frames_[i];
    return s;
  }
  std::uint32_t id(std::size_t i) const { return records_[i].id; }
  glm::vec3 position(std::size_t i) const {
    const Block& b = blocks_[i / kLanes];
    return {b.x[i % kLanes], b.y[i % kLanes], b.z[i % kLanes]};
  }
  float radius(std::size_t i) const { return blocks_[i / kLanes].r[i % kLanes]; }
  glm::vec3 normal(std::size_t i) const {
    const Block& b = blocks_[i / kLanes];
    return {b.nx[i % kLanes], b.ny[i % kLanes], b.nz[i % kLanes]};
  }

  const Block* blocks() const { return blocks_.data(); }  // sample i: block i / 8, lane i % 8
  const Record* records() const { return records_.data(); }

  std::size_t memory_bytes() const {
    return heap_bytes(blocks_) + heap_bytes(records_) + heap_bytes(frames_);
  }

 private:
  // Appends a sample's geometry; the unused lanes of the last block keep radius 0, out of every
  // point's reach.
  void push_geometry(glm::vec3 p, float r, glm::vec3 n) {
    std::size_t i = size();
    if (i % kLanes == 0) blocks_.push_back(Block{});
    Block& b = blocks_.back();
    const std::size_t l = i % kLanes;
    b.x[l] = p.x;
    b.y[l] = p.y;
    b.z[l] = p.z;
    b.reach2[l] = r * r * kSlack;
    b.r[l] = r;
    b.nx[l] = n.x;
    b.ny[l] = n.y;
    b.nz[l] = n.z;
  }

  std::vector<Block> blocks_;
  std::vector<Record> records_;
  std::vector<std::uint32_t> frames_;
};

// Samples [begin, end) of one BlockSamples: the candidates of a voxel or of one or more nodes.
struct Range {
  const BlockSamples* samples;
  std::uint32_t begin, end;
};

// Tests the samples of the ranges against the query and adds the accepted ones to *sum (AVX2 when
// the processor has it, chosen at run time, otherwise SSE2; the same decisions either way).
void scan_ranges(const Range* ranges, unsigned count, const SampleTest& test, WeightedSum* sum);

// Collects the ranges a lookup must test and tests them in batches, so that a lookup enters the
// SIMD kernel once rather than once per level or node.
class RangeScanner {
 public:
  RangeScanner(const SampleTest& test, WeightedSum* sum) : test_(test), sum_(sum) {}

  // A range that starts where the previous one ends extends it. (Ranges that merely lie close are
  // not joined: both backends keep copies of a sample in neighbouring voxels or nodes, which the
  // samples in between could then hold.)
  void add(const BlockSamples* samples, std::uint32_t begin, std::uint32_t end) {
    if (count_ > 0) {
      Range& last = ranges_[count_ - 1];
      if (last.samples == samples && begin == last.end) {
        last.end = end;
        return;
      }
    }
    if (count_ == kMaxRanges) flush();
    ranges_[count_++] = {samples, begin, end};
  }

  void flush() {
    scan_ranges(ranges_.data(), count_, test_, sum_);
    count_ = 0;
  }

 private:
  static constexpr unsigned kMaxRanges = 16;
  const SampleTest& test_;
  WeightedSum* sum_;
  std::array<Range, kMaxRanges> ranges_;
  unsigned count_ = 0;
};

}  // namespace dofcache::cache
