#pragma once
// Storage of cache samples laid out for a lookup loop: SampleColumns, contiguous ranges scanned
// four at a time (the tile buffer; the backends' blocks of eight are in src/cache/block_scan.h).
#include <cstddef>
#include <cstdint>
#include <vector>

#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "dofcache/cache/sample.h"
#include "dofcache/cache/weights.h"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

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

// Samples as columns (structure of arrays), for scanning contiguous ranges: the distance
// prefilter reads x, y, z, r four samples at a time (SSE2, part of the x86-64 baseline); normals,
// ids and values are read only for samples in reach. The tile buffer scans all of its own.
class SampleColumns {
 public:
  std::size_t size() const { return normal_id_.size(); }
  bool empty() const { return normal_id_.empty(); }

  void push_back(const CacheSample& s) {
    std::size_t i = grow();
    x_[i] = s.position.x;
    y_[i] = s.position.y;
    z_[i] = s.position.z;
    r_[i] = s.radius;
    normal_id_.push_back({s.normal, s.id});
    payload_.push_back({s.value, s.frame});
  }
  void append_from(const SampleColumns& o, std::size_t j) {
    std::size_t i = grow();
    x_[i] = o.x_[j];
    y_[i] = o.y_[j];
    z_[i] = o.z_[j];
    r_[i] = o.r_[j];
    normal_id_.push_back(o.normal_id_[j]);
    payload_.push_back(o.payload_[j]);
  }
  void reserve(std::size_t n) {
    for (auto* v : {&x_, &y_, &z_, &r_}) v->reserve(n + kPad);
    normal_id_.reserve(n);
    payload_.reserve(n);
  }
  void clear() {
    for (auto* v : {&x_, &y_, &z_, &r_}) v->clear();
    normal_id_.clear();
    payload_.clear();
  }
  void swap(SampleColumns& o) {
    x_.swap(o.x_);
    y_.swap(o.y_);
    z_.swap(o.z_);
    r_.swap(o.r_);
    normal_id_.swap(o.normal_id_);
    payload_.swap(o.payload_);
  }

  CacheSample get(std::size_t i) const {
    CacheSample s;
    s.position = {x_[i], y_[i], z_[i]};
    s.radius = r_[i];
    s.normal = normal_id_[i].normal;
    s.id = normal_id_[i].id;
    s.value = payload_[i].value;
    s.frame = payload_[i].frame;
    return s;
  }
  std::uint32_t id(std::size_t i) const { return normal_id_[i].id; }
  glm::vec3 position(std::size_t i) const { return {x_[i], y_[i], z_[i]}; }

  // Tests samples [begin, end) against the query and adds the accepted ones to *sum. The SIMD
  // prefilter (||p - p_i||^2 < r_i^2, computed as SampleTest computes it, with a hair of slack)
  // only skips samples that SampleTest::weight would reject; the decision is the scalar test's.
  void test_range(std::uint32_t begin, std::uint32_t end, const SampleTest& test,
                  WeightedSum* sum) const {
    const glm::vec3 p = test.position();
#if defined(__SSE2__)
    const __m128 qx = _mm_set1_ps(p.x), qy = _mm_set1_ps(p.y), qz = _mm_set1_ps(p.z);
    const __m128 slack = _mm_set1_ps(1.0f + 0x1p-20f);
    for (std::uint32_t i = begin; i < end; i += 4) {
      __m128 dx = _mm_sub_ps(qx, _mm_loadu_ps(&x_[i]));
      __m128 dy = _mm_sub_ps(qy, _mm_loadu_ps(&y_[i]));
      __m128 dz = _mm_sub_ps(qz, _mm_loadu_ps(&z_[i]));
      __m128 d2 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)),
                             _mm_mul_ps(dz, dz));
      __m128 r = _mm_loadu_ps(&r_[i]);
      unsigned mask = static_cast<unsigned>(
          _mm_movemask_ps(_mm_cmplt_ps(d2, _mm_mul_ps(_mm_mul_ps(r, r), slack))));
      if (end - i < 4) mask &= (1u << (end - i)) - 1u;
      while (mask) {
        std::uint32_t j = i + static_cast<std::uint32_t>(__builtin_ctz(mask));
        mask &= mask - 1u;
        float w = test.weight({x_[j], y_[j], z_[j]}, r_[j], normal_id_[j].normal);
        if (w > 0.0f) sum->add(normal_id_[j].id, w, payload_[j].value);
      }
    }
#else
    (void)p;
    for (std::uint32_t j = begin; j < end; ++j) {
      float w = test.weight({x_[j], y_[j], z_[j]}, r_[j], normal_id_[j].normal);
      if (w > 0.0f) sum->add(normal_id_[j].id, w, payload_[j].value);
    }
#endif
  }

  std::size_t memory_bytes() const {
    return heap_bytes(x_) + heap_bytes(y_) + heap_bytes(z_) + heap_bytes(r_) +
           heap_bytes(normal_id_) + heap_bytes(payload_);
  }

 private:
  struct NormalId {
    glm::vec3 normal;
    std::uint32_t id;
  };
  struct Payload {
    glm::vec3 value;
    std::uint32_t frame;
  };
  // The prefilter loads four floats at a time and may read up to three past the last sample, so
  // the coordinate columns end with kPad zero-radius entries that no point is within reach of.
  static constexpr std::size_t kPad = 3;
  std::size_t grow() {
    std::size_t i = size();
    for (auto* v : {&x_, &y_, &z_, &r_}) v->resize(i + 1 + kPad, 0.0f);
    return i;
  }

  std::vector<float> x_, y_, z_, r_;
  std::vector<NormalId> normal_id_;
  std::vector<Payload> payload_;
};

}  // namespace dofcache::cache
