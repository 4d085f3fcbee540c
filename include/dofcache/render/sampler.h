#pragma once
// Sample points for pixels, lens and hemispheres. Each 2-D pattern is an Owen-scrambled Sobol
// (0,2)-sequence (Burley 2020): every power-of-two prefix is stratified, every pixel gets its own
// scramble from a hash of (seed, pixel, purpose), so results are reproducible per pixel and do not
// depend on thread count or on which other pixels are rendered.
#include <cstdint>

#include <glm/vec2.hpp>

#include "dofcache/core/rng.h"

namespace dofcache::render {

constexpr std::uint32_t reverse_bits(std::uint32_t x) {
  x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
  x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
  x = ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
  x = ((x >> 8) & 0x00ff00ffu) | ((x & 0x00ff00ffu) << 8);
  return (x >> 16) | (x << 16);
}

// First two Sobol dimensions as 32-bit fixed point: van der Corput and the x+1 polynomial one.
constexpr std::uint32_t sobol_dim0(std::uint32_t i) { return reverse_bits(i); }
constexpr std::uint32_t sobol_dim1(std::uint32_t i) {
  std::uint32_t r = 0;
  for (std::uint32_t v = 1u << 31; i; i >>= 1, v ^= v >> 1)
    if (i & 1u) r ^= v;
  return r;
}

namespace detail {
// sobol_dim1 is linear over GF(2) in the bits of i, so it is the XOR of its values on the four
// bytes of i; stored bit-reversed, as the scramble below wants them. 4 KiB, built at compile time.
struct SobolDim1Tables {
  std::uint32_t reversed[4][256];
};
constexpr SobolDim1Tables make_sobol_dim1_tables() {
  SobolDim1Tables t{};
  for (int b = 0; b < 4; ++b)
    for (std::uint32_t x = 0; x < 256; ++x) t.reversed[b][x] = reverse_bits(sobol_dim1(x << (8 * b)));
  return t;
}
inline constexpr SobolDim1Tables kSobolDim1 = make_sobol_dim1_tables();
}  // namespace detail

// reverse_bits(sobol_dim1(i)) by four table reads instead of a 32-step loop (the same bits).
inline std::uint32_t sobol_dim1_reversed(std::uint32_t i) {
  const auto& t = detail::kSobolDim1.reversed;
  return t[0][i & 0xffu] ^ t[1][(i >> 8) & 0xffu] ^ t[2][(i >> 16) & 0xffu] ^ t[3][i >> 24];
}

// Laine-Karras style hash permutation: applied to bit-reversed values it is a fast nested
// uniform (Owen) scramble.
constexpr std::uint32_t laine_karras_permutation(std::uint32_t x, std::uint32_t seed) {
  x += seed;
  x ^= x * 0x6c50b47cu;
  x ^= x * 0xb82f1e52u;
  x ^= x * 0xc7afe638u;
  x ^= x * 0x8d22f6e6u;
  return x;
}

constexpr std::uint32_t owen_scramble(std::uint32_t x, std::uint32_t seed) {
  return reverse_bits(laine_karras_permutation(reverse_bits(x), seed));
}

// The points of a scrambled, shuffled (0,2)-sequence identified by a key: point i is
// owen_scramble(sobol_dim0(i'), k1) and owen_scramble(sobol_dim1(i'), k2) of the shuffled index
// i' = owen_scramble(i, k0), written with the bit reversals that cancel removed. The three
// scramble seeds are derived from the key once, so loops that draw many points of one pattern (a
// pixel's lens samples, a point's gather rays) pay for the hashing once.
class Sobol2D {
 public:
  explicit Sobol2D(std::uint64_t key)
      : k0_(static_cast<std::uint32_t>(mix64(key))),
        k1_(static_cast<std::uint32_t>(mix64(key ^ 0x5851f42d4c957f2dULL))),
        k2_(static_cast<std::uint32_t>(mix64(key ^ 0x14057b7ef767814fULL))) {}

  glm::vec2 operator()(std::uint32_t index) const {
    std::uint32_t i = owen_scramble(index, k0_);  // shuffle: decorrelates patterns of one pixel
    std::uint32_t x = reverse_bits(laine_karras_permutation(i, k1_));
    std::uint32_t y = reverse_bits(laine_karras_permutation(sobol_dim1_reversed(i), k2_));
    return {static_cast<float>(x >> 8) * 0x1p-24f, static_cast<float>(y >> 8) * 0x1p-24f};
  }

 private:
  std::uint32_t k0_, k1_, k2_;
};

// Point `index` of the pattern identified by `key` (Sobol2D(key)(index)).
inline glm::vec2 sobol_2d(std::uint32_t index, std::uint64_t key) { return Sobol2D(key)(index); }

// Point `index` of a scrambled van der Corput sequence (a 1-D (0,1)-sequence): the first 2^m
// points of any key hold one point in each interval [k / 2^m, (k + 1) / 2^m). reverse_bits(index)
// is the sequence; owen_scramble of it, with the bit reversals that cancel removed, scrambles it.
inline float stratified_1d(std::uint32_t index, std::uint32_t scramble) {
  return static_cast<float>(reverse_bits(laine_karras_permutation(index, scramble)) >> 8) *
         0x1p-24f;
}

// What a pattern is used for; part of its key so that the patterns are independent.
enum class Dimension : std::uint64_t {
  Film = 1, Lens = 2, Gather = 3, Light = 4, Band = 5, Lobe = 6
};

inline std::uint64_t pixel_key(std::uint64_t seed, int x, int y, Dimension d) {
  return hash_combine(hash_combine(seed, (static_cast<std::uint64_t>(y) << 32) | std::uint32_t(x)),
                      static_cast<std::uint64_t>(d));
}

// Chromatic aberration's wavelength bands (lens/aperture.h: 0 red, 1 green, 2 blue). Sample s of
// a pixel carries band kBandOrders[o][s % 3], o drawn per triple of samples from the pixel's band
// key: every three consecutive samples hold one of each band, so a pixel's bands stay balanced at
// any sample count, while the order within a triple does not follow the lens pattern's.
inline constexpr int kBandOrders[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2},
                                          {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};

inline int sample_band(std::uint64_t band_key, std::uint32_t s) {
  return kBandOrders[hash_combine(band_key, s / 3) % 6][s % 3];
}

// How many of the first n samples carry `band`.
inline std::uint32_t band_samples(std::uint64_t band_key, std::uint32_t n, int band) {
  std::uint32_t count = n / 3;
  const int* order = kBandOrders[hash_combine(band_key, n / 3) % 6];
  for (std::uint32_t r = 0; r < n % 3; ++r) count += order[r] == band;
  return count;
}

}  // namespace dofcache::render
