// The layer pyramid's sparse rows (src/preview/kernels.h): a level that is zero outside one run of
// pixels per row is reduced and expanded only over the runs that can be non-zero. The result must
// equal the dense reduce / expand bit for bit, and the runs must cover every non-zero pixel, on odd
// and even sizes, with runs touching the edges and empty rows.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "../../src/preview/kernels.h"

namespace dofcache::preview::detail {
namespace {

constexpr float kGarbage = std::numeric_limits<float>::quiet_NaN();

struct Level {
  int width = 0, height = 0;
  std::vector<Rgba> pixels;
  std::vector<Span> spans;
  RgbaView view() { return {pixels.data(), width, height, width}; }
};

// Random runs (some rows empty, some runs reaching an edge), random values inside, zero outside.
Level random_level(int width, int height, std::mt19937& rng) {
  Level l{width, height, std::vector<Rgba>(static_cast<size_t>(width) * height, Rgba{0, 0, 0, 0}),
          std::vector<Span>(height)};
  std::uniform_int_distribution<int> pick(0, 5), col(0, width);
  std::uniform_real_distribution<float> value(0.0f, 1.0f);
  for (int y = 0; y < height; ++y) {
    const int kind = pick(rng);
    if (kind == 0) continue;  // empty row
    int a = col(rng), b = col(rng);
    if (a > b) std::swap(a, b);
    if (kind == 1) a = 0;
    if (kind == 2) b = width;
    if (a == b) continue;
    l.spans[y] = {a, b};
    for (int x = a; x < b; ++x)
      l.pixels[static_cast<size_t>(y) * width + x] = {value(rng), value(rng), value(rng),
                                                      value(rng)};
  }
  return l;
}

bool same_bits(const Rgba& a, const Rgba& b) {
  return std::memcmp(&a, &b, sizeof a) == 0 ||
         (a.r == b.r && a.g == b.g && a.b == b.b && a.a == b.a);  // +0 and -0
}

bool inside(const Span& s, int x) { return x >= s.x0 && x < s.x1; }

const int kSizes[][2] = {{1, 1}, {2, 3}, {7, 5}, {16, 16}, {33, 18}, {64, 41}};

TEST(SparsePyramid, ReduceEqualsTheDenseReduceAndItsSpansCoverIt) {
  std::mt19937 rng(7);
  ScratchRows scratch;
  for (const auto& size : kSizes)
    for (int trial = 0; trial < 20; ++trial) {
      Level fine = random_level(size[0], size[1], rng);
      const int cw = (fine.width + 1) / 2, ch = (fine.height + 1) / 2;
      std::vector<Rgba> dense(static_cast<size_t>(cw) * ch);
      reduce_box4(fine.view(), {dense.data(), cw, ch, cw}, scratch);

      std::vector<Span> spans;
      reduce_spans(fine.spans.data(), fine.height, cw, ch, spans);
      ASSERT_EQ(spans.size(), static_cast<size_t>(ch));
      std::vector<Rgba> sparse(dense.size(), Rgba{kGarbage, kGarbage, kGarbage, kGarbage});
      reduce_box4(fine.view(), {sparse.data(), cw, ch, cw}, scratch, spans.data());
      // The same from rows produced on demand, only over their runs, into scratch rows that
      // hold garbage from a dense pass before.
      std::vector<Rgba> rows(dense.size());
      std::vector<Span> full(fine.height, Span{0, fine.width});
      reduce_box4_rows(fine.width, fine.height, {rows.data(), cw, ch, cw}, scratch, full.data(),
                       std::vector<Span>(ch, Span{0, cw}).data(),
                       [&](int, int x0, int x1, Rgba* o) {
                         std::fill(o + x0, o + x1, Rgba{kGarbage, kGarbage, kGarbage, kGarbage});
                       });
      reduce_box4_rows(fine.width, fine.height, {rows.data(), cw, ch, cw}, scratch,
                       fine.spans.data(), spans.data(), [&](int y, int x0, int x1, Rgba* o) {
                         const Span& s = fine.spans[y];
                         ASSERT_TRUE(x0 == s.x0 && x1 == s.x1) << "a row asked outside its run";
                         std::copy(fine.pixels.begin() + static_cast<long>(y) * fine.width + x0,
                                   fine.pixels.begin() + static_cast<long>(y) * fine.width + x1,
                                   o + x0);
                       });
      for (int y = 0; y < ch; ++y)
        for (int x = 0; x < cw; ++x) {
          const size_t i = static_cast<size_t>(y) * cw + x;
          ASSERT_TRUE(same_bits(sparse[i], dense[i]))
              << size[0] << "x" << size[1] << " " << x << "," << y;
          ASSERT_TRUE(same_bits(rows[i], dense[i]))
              << size[0] << "x" << size[1] << " " << x << "," << y;
          if (!inside(spans[y], x)) {
            EXPECT_EQ(dense[i].r, 0.0f);
            EXPECT_EQ(dense[i].a, 0.0f);
          }
        }
    }
}

TEST(SparsePyramid, ExpandEqualsTheDenseExpandAndItsSpansCoverIt) {
  std::mt19937 rng(11);
  ScratchRows scratch;
  for (const auto& size : kSizes)
    for (int odd = 0; odd < 2; ++odd)
      for (int trial = 0; trial < 20; ++trial) {
        Level coarse = random_level(size[0], size[1], rng);
        // Fine sizes whose halves round up to the coarse size.
        const int fw = std::max(1, 2 * coarse.width - odd),
                  fh = std::max(1, 2 * coarse.height - odd);
        std::vector<Rgba> dense(static_cast<size_t>(fw) * fh);
        expand_bspline2(coarse.view(), fw, fh, scratch, [&](int y, const Rgba* row, Span s) {
          ASSERT_TRUE(s.x0 == 0 && s.x1 == fw);
          std::copy(row, row + fw, dense.begin() + static_cast<long>(y) * fw);
        });
        std::vector<Span> spans;
        expand_spans(coarse.spans.data(), coarse.height, fw, fh, spans);
        ASSERT_EQ(spans.size(), static_cast<size_t>(fh));
        std::vector<int> stored(fh, 0);
        expand_bspline2(
            coarse.view(), fw, fh, scratch,
            [&](int y, const Rgba* row, Span s) {
              ++stored[y];
              ASSERT_TRUE(s.x0 == spans[y].x0 && s.x1 == spans[y].x1);
              for (int x = 0; x < fw; ++x) {
                const Rgba& d = dense[static_cast<size_t>(y) * fw + x];
                if (inside(s, x))
                  ASSERT_TRUE(same_bits(row[x], d)) << fw << "x" << fh << " " << x << "," << y;
                else
                  ASSERT_TRUE(d.r == 0 && d.g == 0 && d.b == 0 && d.a == 0)
                      << "non-zero outside the span at " << x << "," << y;
              }
            },
            spans.data());
        for (int y = 0; y < fh; ++y) EXPECT_EQ(stored[y], 1);
      }
}

TEST(SparsePyramid, ReduceThenExpandSpansCoverTheSpansTheyStartFrom) {
  // The mix of two levels relies on it: the expand's spans hold the level's own.
  std::mt19937 rng(3);
  for (const auto& size : kSizes)
    for (int trial = 0; trial < 50; ++trial) {
      Level l = random_level(size[0], size[1], rng);
      const int cw = (l.width + 1) / 2, ch = (l.height + 1) / 2;
      std::vector<Span> coarse, back;
      reduce_spans(l.spans.data(), l.height, cw, ch, coarse);
      expand_spans(coarse.data(), ch, l.width, l.height, back);
      for (int y = 0; y < l.height; ++y) {
        const Span& s = l.spans[y];
        if (s.empty()) continue;
        EXPECT_LE(back[y].x0, s.x0);
        EXPECT_GE(back[y].x1, s.x1);
      }
    }
}

}  // namespace
}  // namespace dofcache::preview::detail
