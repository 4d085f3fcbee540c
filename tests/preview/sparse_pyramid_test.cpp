// The layer pyramid's sparse rows (src/preview/kernels.h): a level that is zero outside a few runs
// of pixels per row is reduced and expanded only over the runs that can be non-zero. The result
// must equal the dense reduce / expand bit for bit, and the runs must cover every non-zero pixel,
// on odd and even sizes, with empty rows, runs touching the edges and more runs than a row keeps.
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
  std::vector<Runs> runs;
  RgbaView view() { return {pixels.data(), width, height, width}; }
};

// Random runs per row (none to six, some reaching an edge, some close enough to merge), random
// values inside, zero outside.
Level random_level(int width, int height, std::mt19937& rng) {
  Level l{width, height, std::vector<Rgba>(static_cast<size_t>(width) * height, Rgba{0, 0, 0, 0}),
          std::vector<Runs>(height)};
  std::uniform_int_distribution<int> count(0, 6), col(0, width);
  std::uniform_real_distribution<float> value(0.0f, 1.0f);
  for (int y = 0; y < height; ++y) {
    std::vector<int> cuts(2 * count(rng));
    for (int& c : cuts) c = col(rng);
    std::sort(cuts.begin(), cuts.end());
    for (size_t k = 0; k < cuts.size(); k += 2) {
      const Span s{cuts[k], cuts[k + 1]};
      if (s.empty()) continue;
      l.runs[y].append(s);
      for (int x = s.x0; x < s.x1; ++x)
        l.pixels[static_cast<size_t>(y) * width + x] = {value(rng), value(rng), value(rng),
                                                        value(rng)};
    }
  }
  return l;
}

bool same_bits(const Rgba& a, const Rgba& b) {
  return std::memcmp(&a, &b, sizeof a) == 0 ||
         (a.r == b.r && a.g == b.g && a.b == b.b && a.a == b.a);  // +0 and -0
}

bool inside(const Runs& r, int x) {
  for (const Span& s : r)
    if (x >= s.x0 && x < s.x1) return true;
  return false;
}

const int kSizes[][2] = {{1, 1}, {2, 3}, {7, 5}, {16, 16}, {33, 18}, {64, 41}, {150, 9}};

TEST(SparsePyramid, RunsStaySortedDisjointAndCoverWhatIsAdded) {
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> col(0, 200), len(1, 12);
  for (int trial = 0; trial < 200; ++trial) {
    Runs r;
    std::vector<Span> added;
    int x = col(rng) % 10;
    for (int k = 0; k < 10; ++k) {
      const Span s{x, x + len(rng)};
      r.append(s);
      added.push_back(s);
      x = s.x0 + len(rng) * (k % 3) * 3;  // overlapping, touching or apart
    }
    ASSERT_LE(r.n, Runs::kMax);
    for (int k = 0; k + 1 < r.n; ++k) EXPECT_GT(r.run[k + 1].x0, r.run[k].x1 + Runs::kJoin);
    for (const Span& s : added)
      for (int p = s.x0; p < s.x1; ++p) ASSERT_TRUE(inside(r, p)) << p;
    std::vector<Rgba> row(1024, Rgba{1, 1, 1, 1});
    r.zero_outside(row.data(), 0, 1024);
    for (int p = 0; p < 1024; ++p) EXPECT_EQ(row[p].a, inside(r, p) ? 1.0f : 0.0f) << p;
  }
}

TEST(SparsePyramid, ReduceEqualsTheDenseReduceAndItsRunsCoverIt) {
  std::mt19937 rng(7);
  ScratchRows scratch;
  for (const auto& size : kSizes)
    for (int trial = 0; trial < 20; ++trial) {
      Level fine = random_level(size[0], size[1], rng);
      const int cw = (fine.width + 1) / 2, ch = (fine.height + 1) / 2;
      std::vector<Rgba> dense(static_cast<size_t>(cw) * ch);
      reduce_box4(fine.view(), {dense.data(), cw, ch, cw}, scratch);

      std::vector<Runs> runs;
      reduce_runs(fine.runs.data(), fine.height, cw, ch, runs);
      ASSERT_EQ(runs.size(), static_cast<size_t>(ch));
      std::vector<Rgba> sparse(dense.size(), Rgba{kGarbage, kGarbage, kGarbage, kGarbage});
      reduce_box4(fine.view(), {sparse.data(), cw, ch, cw}, scratch, runs.data());
      // The same from rows produced on demand, only over their runs, into scratch rows that
      // hold garbage from a dense pass before.
      std::vector<Rgba> rows(dense.size());
      std::vector<Runs> full(fine.height, Runs::whole(fine.width));
      reduce_box4_rows(fine.width, fine.height, {rows.data(), cw, ch, cw}, scratch, full.data(),
                       std::vector<Runs>(ch, Runs::whole(cw)).data(),
                       [&](int, int x0, int x1, Rgba* o) {
                         std::fill(o + x0, o + x1, Rgba{kGarbage, kGarbage, kGarbage, kGarbage});
                       });
      reduce_box4_rows(
          fine.width, fine.height, {rows.data(), cw, ch, cw}, scratch, fine.runs.data(),
          runs.data(), [&](int y, int x0, int x1, Rgba* o) {
            ASSERT_TRUE(x0 < x1 && inside(fine.runs[y], x0) && inside(fine.runs[y], x1 - 1))
                << "a row asked outside its runs";
            std::copy(fine.pixels.begin() + static_cast<long>(y) * fine.width + x0,
                      fine.pixels.begin() + static_cast<long>(y) * fine.width + x1, o + x0);
          });
      for (int y = 0; y < ch; ++y)
        for (int x = 0; x < cw; ++x) {
          const size_t i = static_cast<size_t>(y) * cw + x;
          ASSERT_TRUE(same_bits(sparse[i], dense[i]))
              << size[0] << "x" << size[1] << " " << x << "," << y;
          ASSERT_TRUE(same_bits(rows[i], dense[i]))
              << size[0] << "x" << size[1] << " " << x << "," << y;
          if (!inside(runs[y], x)) {
            EXPECT_EQ(dense[i].r, 0.0f);
            EXPECT_EQ(dense[i].a, 0.0f);
          }
        }
    }
}

TEST(SparsePyramid, ExpandEqualsTheDenseExpandAndItsRunsCoverIt) {
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
        expand_bspline2(coarse.view(), fw, fh, scratch, [&](int y, const Rgba* row, const Runs& r) {
          ASSERT_TRUE(r.n == 1 && r.run[0].x0 == 0 && r.run[0].x1 == fw);
          std::copy(row, row + fw, dense.begin() + static_cast<long>(y) * fw);
        });
        std::vector<Runs> runs;
        expand_runs(coarse.runs.data(), coarse.height, fw, fh, runs);
        ASSERT_EQ(runs.size(), static_cast<size_t>(fh));
        std::vector<int> stored(fh, 0);
        expand_bspline2(
            coarse.view(), fw, fh, scratch,
            [&](int y, const Rgba* row, const Runs& r) {
              ++stored[y];
              ASSERT_EQ(&r, &runs[y]);
              for (int x = 0; x < fw; ++x) {
                const Rgba& d = dense[static_cast<size_t>(y) * fw + x];
                if (inside(r, x))
                  ASSERT_TRUE(same_bits(row[x], d)) << fw << "x" << fh << " " << x << "," << y;
                else
                  ASSERT_TRUE(d.r == 0 && d.g == 0 && d.b == 0 && d.a == 0)
                      << "non-zero outside the span at " << x << "," << y;
              }
            },
            runs.data());
        for (int y = 0; y < fh; ++y) EXPECT_EQ(stored[y], 1);
      }
}

TEST(SparsePyramid, ReduceThenExpandRunsCoverTheRunsTheyStartFrom) {
  // The mix of two levels relies on it: the expand's runs hold the level's own.
  std::mt19937 rng(3);
  for (const auto& size : kSizes)
    for (int trial = 0; trial < 50; ++trial) {
      Level l = random_level(size[0], size[1], rng);
      const int cw = (l.width + 1) / 2, ch = (l.height + 1) / 2;
      std::vector<Runs> coarse, back;
      reduce_runs(l.runs.data(), l.height, cw, ch, coarse);
      expand_runs(coarse.data(), ch, l.width, l.height, back);
      for (int y = 0; y < l.height; ++y)
        for (const Span& s : l.runs[y])
          for (int x = s.x0; x < s.x1; ++x) ASSERT_TRUE(inside(back[y], x)) << x << "," << y;
    }
}

}  // namespace
}  // namespace dofcache::preview::detail
