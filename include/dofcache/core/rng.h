#pragma once
// Counter-based random numbers: every pixel sample gets its own stream derived from
// (seed, pixel, sample index), so images do not depend on thread count or tile order.
#include <cstdint>

namespace dofcache {

// 64-bit finaliser of MurmurHash3 / SplitMix64: a fast, well-mixed hash of one integer.
constexpr std::uint64_t mix64(std::uint64_t x) {
  x ^= x >> 33;
  x *= 0xff51afd7ed558ccdULL;
  x ^= x >> 33;
  x *= 0xc4ceb9fe1a85ec53ULL;
  x ^= x >> 33;
  return x;
}

constexpr std::uint64_t hash_combine(std::uint64_t a, std::uint64_t b) {
  return mix64(a ^ (mix64(b) + 0x9e3779b97f4a7c15ULL + (a << 6) + (a >> 2)));
}

// PCG32 (O'Neill 2014): small state, good statistics, cheap to seed per sample.
class Rng {
 public:
  constexpr Rng() = default;
  constexpr explicit Rng(std::uint64_t seed, std::uint64_t stream = 0) { reseed(seed, stream); }

  constexpr void reseed(std::uint64_t seed, std::uint64_t stream = 0) {
    state_ = 0;
    inc_ = (mix64(stream) << 1u) | 1u;
    next_u32();
    state_ += mix64(seed);
    next_u32();
  }

  constexpr std::uint32_t next_u32() {
    std::uint64_t old = state_;
    state_ = old * 6364136223846793005ULL + inc_;
    auto xorshifted = static_cast<std::uint32_t>(((old >> 18u) ^ old) >> 27u);
    auto rot = static_cast<std::uint32_t>(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((32u - rot) & 31u));
  }

  // Uniform float in [0, 1): 24 random mantissa bits, never rounds up to 1.
  constexpr float uniform() { return static_cast<float>(next_u32() >> 8) * 0x1p-24f; }

  // Uniform integer in [0, n).
  constexpr std::uint32_t uniform_index(std::uint32_t n) {
    return static_cast<std::uint32_t>((static_cast<std::uint64_t>(next_u32()) * n) >> 32);
  }

 private:
  std::uint64_t state_ = 0x853c49e6748fea9bULL;
  std::uint64_t inc_ = 0xda3e39cb94b95bdbULL;
};

}  // namespace dofcache
