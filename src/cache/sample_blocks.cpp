#include "dofcache/cache/sample_blocks.h"

#include <algorithm>

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace dofcache::cache {
namespace {

// The scalar test of sample `lane` of block k, added to *sum if accepted.
inline __attribute__((always_inline)) void test_lane(const BlockSamples& samples,
                                                     std::uint32_t k, unsigned lane,
                                                     const SampleTest& test, WeightedSum* sum) {
  const BlockSamples::Block& b = samples.blocks()[k];
  const float w = test.weight({b.x[lane], b.y[lane], b.z[lane]}, b.r[lane],
                              {b.nx[lane], b.ny[lane], b.nz[lane]});
  if (w > 0.0f) {
    const BlockSamples::Record& record = samples.records()[k * BlockSamples::kLanes + lane];
    sum->add(record.id, w, record.value);
  }
}

// The samples that passed the prefilter, collected without a branch per block and tested
// together afterwards: which blocks have a sample in reach follows no pattern, and a mispredicted
// branch per such block costs more than the whole prefilter.
class Candidates {
 public:
  // Room for the blocks noted between two test() calls, kept apart from the counters so that
  // those stay in registers.
  struct Noted {
    const BlockSamples* samples;
    std::uint32_t k;  // block
  };
  static constexpr unsigned kMaxBlocks = 64 / BlockSamples::kLanes;
  using Storage = std::array<Noted, kMaxBlocks>;

  Candidates(Storage* blocks, const SampleTest& test, WeightedSum* sum)
      : blocks_(blocks->data()), test_(test), sum_(sum) {}

  // Where to stop noting the blocks k, k + 1, ... of a range (last block k_last) to keep room for
  // its last block; the candidates are tested first if there is none.
  std::uint32_t stop(std::uint32_t k, std::uint32_t k_last) {
    if (count_ == kMaxBlocks) test();
    return std::min(k_last, k + (kMaxBlocks - 1 - count_));
  }

  // Notes the lanes of block k that passed (mask, possibly 0). There must be room (stop()).
  void note(const BlockSamples* samples, std::uint32_t k, unsigned mask) {
    blocks_[count_] = {samples, k};
    lanes_ |= static_cast<std::uint64_t>(mask) << (BlockSamples::kLanes * count_);
    count_ += mask != 0;
  }

  // The scalar test of every candidate noted so far.
  __attribute__((always_inline)) void test() {
    while (lanes_) {
      const auto bit = static_cast<unsigned>(__builtin_ctzll(lanes_));
      lanes_ &= lanes_ - 1;
      const Noted& noted = blocks_[bit / BlockSamples::kLanes];
      test_lane(*noted.samples, noted.k, bit % BlockSamples::kLanes, test_, sum_);
    }
    count_ = 0;
  }

 private:
  Noted* blocks_;
  const SampleTest& test_;
  WeightedSum* sum_;
  unsigned count_ = 0;
  std::uint64_t lanes_ = 0;  // bit 8 i + lane: that lane of blocks_[i] passed
};

// The lanes of the range in its first and in its last block (bit l: lane l).
inline unsigned first_lanes(const Range& range) {
  return (0xFFu << (range.begin % BlockSamples::kLanes)) & 0xFFu;
}
inline unsigned last_lanes(const Range& range) {
  return 0xFFu >> (BlockSamples::kLanes - 1 - (range.end - 1) % BlockSamples::kLanes);
}

// The blocks of each range through `prefilter` (a block -> the mask of its lanes in reach), noted
// in chunks that leave the candidates room for the range's last block, then the scalar test of
// the candidates. Inlined into each kernel, so it is compiled for that kernel's instruction set.
template <typename Prefilter>
__attribute__((always_inline)) inline void scan_blocks(const Range* ranges, unsigned count,
                                                       Candidates& candidates,
                                                       const Prefilter& prefilter) {
  for (const Range* range = ranges; range != ranges + count; ++range) {
    const BlockSamples* samples = range->samples;
    const BlockSamples::Block* blocks = samples->blocks();
    const std::uint32_t k_last = (range->end - 1) / BlockSamples::kLanes;
    std::uint32_t k = range->begin / BlockSamples::kLanes;
    unsigned lanes = first_lanes(*range);
    for (;;) {
      for (const std::uint32_t stop = candidates.stop(k, k_last); k < stop; ++k, lanes = 0xFFu)
        candidates.note(samples, k, prefilter(blocks[k]) & lanes);
      if (k == k_last) break;
      candidates.test();
    }
    candidates.note(samples, k, prefilter(blocks[k]) & lanes & last_lanes(*range));
  }
  candidates.test();
}

// Tests the samples of the ranges against the query and adds the accepted ones to *sum. A
// prefilter, ||p - p_i||^2 < r_i^2 (1 + 2^-20) (the block's reach2) with the distance computed in
// the order SampleTest computes it, picks the candidates: it only skips samples that
// SampleTest::weight rejects, and the decision is the scalar test's, so every backend accepts the
// same samples with the same weights. It tests whole blocks, the lanes outside the range masked
// off: half a block per SSE2 instruction here (the x86-64 baseline), a whole one in
// scan_ranges_avx2. Neither uses fused multiply-add.
void scan_ranges_baseline(const Range* ranges, unsigned count, const SampleTest& test,
                          WeightedSum* sum) {
  Candidates::Storage storage;
  Candidates candidates(&storage, test, sum);
#if defined(__SSE2__)
  const glm::vec3 p = test.position();
  const __m128 qx = _mm_set1_ps(p.x), qy = _mm_set1_ps(p.y), qz = _mm_set1_ps(p.z);
  auto half = [&](const float* x, const float* y, const float* z, const float* reach2) {
    __m128 dx = _mm_sub_ps(qx, _mm_load_ps(x));
    __m128 dy = _mm_sub_ps(qy, _mm_load_ps(y));
    __m128 dz = _mm_sub_ps(qz, _mm_load_ps(z));
    __m128 d2 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)), _mm_mul_ps(dz, dz));
    return static_cast<unsigned>(_mm_movemask_ps(_mm_cmplt_ps(d2, _mm_load_ps(reach2))));
  };
  auto prefilter = [&](const BlockSamples::Block& b) {
    return half(b.x, b.y, b.z, b.reach2) | half(b.x + 4, b.y + 4, b.z + 4, b.reach2 + 4) << 4;
  };
#else
  auto prefilter = [](const BlockSamples::Block&) { return 0xFFu; };
#endif
  scan_blocks(ranges, count, candidates, prefilter);
}

#if defined(__x86_64__)
// The prefilter of one block, eight lanes per instruction (AVX2: not in the x86-64 baseline, so
// chosen at run time).
__attribute__((target("avx2"), always_inline)) inline unsigned prefilter_avx2(
    const BlockSamples::Block& b, __m256 qx, __m256 qy, __m256 qz) {
  const __m256 dx = _mm256_sub_ps(qx, _mm256_load_ps(b.x));
  const __m256 dy = _mm256_sub_ps(qy, _mm256_load_ps(b.y));
  const __m256 dz = _mm256_sub_ps(qz, _mm256_load_ps(b.z));
  const __m256 d2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)),
                                  _mm256_mul_ps(dz, dz));
  return static_cast<unsigned>(
      _mm256_movemask_ps(_mm256_cmp_ps(d2, _mm256_load_ps(b.reach2), _CMP_LT_OQ)));
}

__attribute__((target("avx2"))) void scan_ranges_avx2(const Range* ranges, unsigned count,
                                                      const SampleTest& test, WeightedSum* sum) {
  Candidates::Storage storage;
  Candidates candidates(&storage, test, sum);
  const glm::vec3 p = test.position();
  const __m256 qx = _mm256_set1_ps(p.x), qy = _mm256_set1_ps(p.y), qz = _mm256_set1_ps(p.z);
  auto prefilter = [&](const BlockSamples::Block& b) __attribute__((target("avx2"))) {
    return prefilter_avx2(b, qx, qy, qz);
  };
  scan_blocks(ranges, count, candidates, prefilter);
}

const bool kHaveAvx2 = [] {
  __builtin_cpu_init();  // may run before libgcc's own initialisation
  return __builtin_cpu_supports("avx2") != 0;
}();
#endif

}  // namespace

void scan_ranges(const Range* ranges, unsigned count, const SampleTest& test, WeightedSum* sum) {
#if defined(__x86_64__)
  if (kHaveAvx2) return scan_ranges_avx2(ranges, count, test, sum);
#endif
  scan_ranges_baseline(ranges, count, test, sum);
}

}  // namespace dofcache::cache
