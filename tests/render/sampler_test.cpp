// The Sobol sampler: the table-driven fast path against the definitions it replaces.
#include <gtest/gtest.h>

#include <cstdlib>
#include <vector>

#include "dofcache/render/sampler.h"

namespace dofcache::render {
namespace {

TEST(Sampler, SobolDim1FirstPoints) {
  // Direction numbers v1 = 1/2, v2 = 3/4, v3 = 5/8 (v_k = v_{k-1} xor v_{k-1} / 2), 32-bit fixed point.
  EXPECT_EQ(sobol_dim1(0), 0u);
  EXPECT_EQ(sobol_dim1(1), 0x80000000u);
  EXPECT_EQ(sobol_dim1(2), 0xc0000000u);
  EXPECT_EQ(sobol_dim1(3), 0x40000000u);
  EXPECT_EQ(sobol_dim1(4), 0xa0000000u);
}

TEST(Sampler, TableDim1MatchesTheLoop) {
  std::uint32_t i = 0x9e3779b9u;
  for (int k = 0; k < 20000; ++k, i = i * 1664525u + 1013904223u) {
    ASSERT_EQ(sobol_dim1_reversed(i), reverse_bits(sobol_dim1(i))) << i;
    ASSERT_EQ(sobol_dim1_reversed(k), reverse_bits(sobol_dim1(k))) << k;
  }
}

TEST(Sampler, Sobol2dIsTheScrambledSequence) {
  // The definition: shuffle the index, then Owen-scramble both dimensions.
  for (std::uint64_t key : {1ull, 0x123456789abcdefull, ~0ull}) {
    auto k0 = static_cast<std::uint32_t>(mix64(key));
    auto k1 = static_cast<std::uint32_t>(mix64(key ^ 0x5851f42d4c957f2dULL));
    auto k2 = static_cast<std::uint32_t>(mix64(key ^ 0x14057b7ef767814fULL));
    for (std::uint32_t n = 0; n < 4096; ++n) {
      std::uint32_t i = owen_scramble(n, k0);
      float x = static_cast<float>(owen_scramble(sobol_dim0(i), k1) >> 8) * 0x1p-24f;
      float y = static_cast<float>(owen_scramble(sobol_dim1(i), k2) >> 8) * 0x1p-24f;
      glm::vec2 p = sobol_2d(n, key);
      ASSERT_EQ(p.x, x) << n;
      ASSERT_EQ(p.y, y) << n;
    }
  }
}

TEST(Sampler, EveryPowerOfTwoPrefixIsStratified) {
  // (0,2)-sequence: the first 16 points put one point in each 4x4 cell (elementary intervals).
  int cells[4][4] = {};
  for (std::uint32_t n = 0; n < 16; ++n) {
    glm::vec2 p = sobol_2d(n, 77);
    ++cells[static_cast<int>(p.x * 4)][static_cast<int>(p.y * 4)];
  }
  for (auto& row : cells)
    for (int c : row) EXPECT_EQ(c, 1);
}


// The pixel's stratified 1-D pattern (rough-lobe decisions): the first 2^m points of any
// scramble put one point in each interval [k / 2^m, (k + 1) / 2^m), so the number below any p
// among them is within 1 of 2^m p; different scrambles give different points.
TEST(Sampler, Stratified1dPutsOnePointInEachIntervalOfEveryPowerOfTwoPrefix) {
  int first_points_differ = 0;
  for (std::uint32_t scramble : {0u, 1u, 0x9e3779b9u, 0xdeadbeefu, ~0u}) {
    for (int m = 0; m <= 10; ++m) {
      const std::uint32_t n = 1u << m;
      std::vector<int> cells(n, 0);
      for (std::uint32_t s = 0; s < n; ++s) {
        const float u = stratified_1d(s, scramble);
        ASSERT_GE(u, 0.0f);
        ASSERT_LT(u, 1.0f);
        ++cells[static_cast<std::size_t>(u * n)];
      }
      for (std::uint32_t c = 0; c < n; ++c) ASSERT_EQ(cells[c], 1) << "m " << m << " cell " << c;
      for (float p : {1.0f / 16.0f, 0.3f, 0.77f}) {
        int below = 0;
        for (std::uint32_t s = 0; s < n; ++s) below += stratified_1d(s, scramble) < p;
        EXPECT_LE(std::abs(below - static_cast<double>(n) * p), 1.0) << "m " << m << " p " << p;
      }
    }
    first_points_differ += stratified_1d(0, scramble) != stratified_1d(0, 0x12345u);
  }
  EXPECT_GE(first_points_differ, 4);
}

// Chromatic aberration's bands: every three consecutive samples carry one of each, and
// band_samples counts what sample_band hands out, for every count.
TEST(Sampler, BandsStayBalancedAndAreCountedExactly) {
  for (std::uint64_t key : {1ull, 0x9e3779b97f4a7c15ull, 12345ull}) {
    int counts[3] = {0, 0, 0};
    bool orders_differ = false;
    for (std::uint32_t s = 0; s < 300; ++s) {
      const int b = sample_band(key, s);
      ASSERT_TRUE(b >= 0 && b <= 2);
      ++counts[b];
      if (s % 3 == 2) {
        EXPECT_EQ(counts[0], counts[1]);
        EXPECT_EQ(counts[1], counts[2]);
      }
      if (s >= 3 && sample_band(key, s) != sample_band(key, s - 3)) orders_differ = true;
      for (int band = 0; band < 3; ++band)
        EXPECT_EQ(band_samples(key, s + 1, band), static_cast<std::uint32_t>(counts[band]));
    }
    EXPECT_TRUE(orders_differ);  // the order is drawn per triple, not fixed
  }
}
}  // namespace
}  // namespace dofcache::render
