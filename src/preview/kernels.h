#pragma once
// Internal building blocks of the preview: an RGBA value type, row-parallel loops, per-thread
// scratch rows, the pyramid reduce/expand on RGBA buffers and the pull-push levels.
#include "dofcache/core/stopwatch.h"
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

namespace dofcache::preview::detail {

struct alignas(16) Rgba {
  float r, g, b, a;
};
// The arithmetic goes through a 4-float vector type so that it maps to single SIMD instructions.
typedef float Float4 __attribute__((vector_size(16)));
inline Float4 as_vec(const Rgba& x) {
  Float4 v;
  std::memcpy(&v, &x, sizeof v);
  return v;
}
inline Rgba as_rgba(Float4 v) {
  Rgba x;
  std::memcpy(&x, &v, sizeof x);
  return x;
}
inline Rgba operator+(const Rgba& x, const Rgba& y) { return as_rgba(as_vec(x) + as_vec(y)); }
inline Rgba operator*(const Rgba& x, float s) { return as_rgba(as_vec(x) * s); }

// f(y_begin, y_end) over [0, rows) in parallel chunks of at least `grain` rows.
template <class F>
void parallel_rows(int rows, const F& f, int grain = 4) {
  if (rows <= 0) return;
  tbb::parallel_for(tbb::blocked_range<int>(0, rows, grain),
                    [&](const tbb::blocked_range<int>& r) { f(r.begin(), r.end()); });
}

// Few bits are ever set in the masks counted here (a pixel is revealed by one or two layers): clear
// them one by one rather than call the generic routine (no POPCNT without -march flags).
inline int popcount64(std::uint64_t v) {
  int c = 0;
  for (; v; v &= v - 1) ++c;
  return c;
}
inline int ctz64(std::uint64_t v) { return __builtin_ctzll(v); }

template <class T>
void ensure_size(std::vector<T>& v, size_t n) {
  if (v.size() < n) v.resize(n);
}

// A 2D window into a row-major RGBA buffer.
struct RgbaView {
  Rgba* data = nullptr;
  int width = 0, height = 0;
  std::ptrdiff_t stride = 0;  // elements between rows
  Rgba* row(int y) const { return data + y * stride; }
};

// Per-thread scratch rows (grown on demand, never shrunk).
class ScratchRows {
 public:
  Rgba* get(int slot, size_t n) {
    auto& rows = local_.local();
    if (rows.size() <= static_cast<size_t>(slot)) rows.resize(slot + 1);
    ensure_size(rows[slot], n);
    return rows[slot].data();
  }

 private:
  tbb::enumerable_thread_specific<std::vector<std::vector<Rgba>>> local_;
};

// A run [x0, x1) of pixels.
struct Span {
  int x0 = 0, x1 = 0;
  bool empty() const { return x0 >= x1; }
};
// Sets row[a, b) to zero (nothing if a >= b).
inline void zero_run(Rgba* row, int a, int b) {
  if (a < b) std::fill(row + a, row + b, Rgba{0, 0, 0, 0});
}

// A row's runs of pixels outside which it is zero: left to right, disjoint, at most kMax (beyond
// that the nearest two merge), and runs less than kJoin pixels apart merge (a few zeros cost less
// than another loop). A layer's pyramid follows them: most layers hold a few bars or the floor,
// and the rest of each row would reduce and expand zeros.
struct Runs {
  static constexpr int kMax = 4, kJoin = 8;
  int n = 0;
  Span run[kMax];

  static Runs whole(int width) {
    Runs r;
    if (width > 0) r.run[r.n++] = {0, width};
    return r;
  }
  bool empty() const { return n == 0; }
  const Span* begin() const { return run; }
  const Span* end() const { return run + n; }
  Span bounds() const { return n ? Span{run[0].x0, run[n - 1].x1} : Span{}; }
  // Adds non-empty s, which starts at or after every run so far.
  void append(const Span& s) {
    if (n && s.x0 <= run[n - 1].x1 + kJoin) {
      run[n - 1].x1 = std::max(run[n - 1].x1, s.x1);
      return;
    }
    if (n == kMax) {  // close the narrowest gap, s's included
      int k = n - 1;  // gap k lies after run k; gap n - 1 is s's
      auto gap = [&](int g) { return (g + 1 < n ? run[g + 1].x0 : s.x0) - run[g].x1; };
      for (int g = 0; g + 1 < n; ++g)
        if (gap(g) < gap(k)) k = g;
      if (k == n - 1) {
        run[n - 1].x1 = std::max(run[n - 1].x1, s.x1);
        return;
      }
      run[k].x1 = run[k + 1].x1;
      for (int g = k + 1; g + 1 < n; ++g) run[g] = run[g + 1];
      --n;
    }
    run[n++] = s;
  }
  // Sets row[a, b) to zero outside the runs.
  void zero_outside(Rgba* row, int a, int b) const {
    int x = a;
    for (const Span& r : *this) {
      zero_run(row, x, std::min(r.x0, b));
      x = std::max(x, r.x1);
    }
    zero_run(row, x, b);
  }
};
// The union of two rows' runs (merged as Runs::append merges).
Runs unite(const Runs& a, const Runs& b);
// The runs of a reduce_box4 level from those of the finer level (coarse pixel m sees fine pixels
// 2m-1 .. 2m+2 on each axis), and of an expand_bspline2 level from those of the coarser level (fine
// pixel x sees coarse pixels x/2 - 1 .. x/2 + 1): each a superset of where the result can be
// non-zero. A reduce followed by an expand gives a superset of the runs it started from.
void reduce_runs(const Runs* fine, int fine_height, int coarse_width, int coarse_height,
                 std::vector<Runs>& coarse);
void expand_runs(const Runs* coarse, int coarse_height, int fine_width, int fine_height,
                 std::vector<Runs>& fine);

// One coarse row of the 4x4 box reduce from the four fine rows r0..r3 it covers: vertical sums
// into tmp (with tmp[-1], tmp[fw], tmp[fw+1] writable for the repeated edges), then horizontal sums
// into out. Only the coarse pixels of `runs` are computed (from the fine pixels they see); the rest
// of out is set to zero. Shared by both reduce_box4 variants.
inline void reduce_box4_row(const Rgba* r0, const Rgba* r1, const Rgba* r2, const Rgba* r3,
                            Rgba* tmp, int fw, Rgba* out, int cw, const Runs& runs) {
  runs.zero_outside(out, 0, cw);
  for (const Span& s : runs) {
    const int fa = std::max(2 * s.x0 - 1, 0), fb = std::min(2 * s.x1 + 1, fw);
    for (int x = fa; x < fb; ++x) tmp[x] = (r0[x] + r1[x]) + (r2[x] + r3[x]);
    if (fa == 0) tmp[-1] = tmp[0];
    if (fb == fw) tmp[fw] = tmp[fw + 1] = tmp[fw - 1];
    for (int x = s.x0; x < s.x1; ++x)
      out[x] = ((tmp[2 * x - 1] + tmp[2 * x]) + (tmp[2 * x + 1] + tmp[2 * x + 2])) * 0.0625f;
  }
}

// 4x4 box reduce (Kraus & Strengert 2007): coarse pixel m covers fine pixels 2m-1 .. 2m+2 on each
// axis (clamped to the edge). coarse must be ceil(fine/2) in each dimension. With `runs` (one per
// coarse row, from reduce_runs) only those pixels are computed; the rest of coarse is zero.
void reduce_box4(const RgbaView& fine, const RgbaView& coarse, ScratchRows& scratch,
                 const Runs* runs = nullptr);

// reduce_box4 from rows produced on demand: src(y, x0, x1, out) writes pixels [x0, x1) of fine
// row y into out[x0, x1), for each of fine_runs[y]; the fine row is zero outside them (the other
// pixels are zeroed here). Each fine row is produced about once (a ring of four rows per task),
// so the fine level never has to exist as a whole.
template <class RowSource>
void reduce_box4_rows(int fine_width, int fine_height, const RgbaView& coarse, ScratchRows& scratch,
                      const Runs* fine_runs, const Runs* coarse_runs, const RowSource& src);

// Biquadratic B-spline expand: fine pixel x lies at coarse coordinate x/2 - 1/4; taps (m-1, m,
// m+1) with m = x/2 have weights (9/32, 22/32, 1/32) for even x and (1/32, 22/32, 9/32) for odd x
// (the quadratic B-spline at distances 3/4, 1/4, 5/4). store(y, row, runs) receives every fine
// row: row[x] for x in the runs, zero elsewhere (not written); without `runs` (one per fine row,
// from expand_runs) the run is the whole row.
template <class Store>
void expand_bspline2(const RgbaView& coarse, int fine_width, int fine_height, ScratchRows& scratch,
                     const Store& store, const Runs* runs = nullptr);

// Pull-push levels for C channels plus a weight (interleaved, C + 1 floats per pixel).
struct PullPushLevel {
  int width = 0, height = 0;
  std::vector<float> data;
};
// The pull's reduce: Kraus & Strengert's 2x2 box, or the overlapping separable tent [1 3 3 1] / 4,
// whose coarse cells also see the cells across their edges, so that a hole's fill next to known
// pixels comes from them even where the hole's edge falls on cell boundaries (the slab composite's
// backing along a contour needs that; it costs about 1.5 ms per 640x480 frame).
enum class PullFilter { Box, Tent };
// Pulls levels base+1 .. n-1 (1x1) from `levels[base]` (already filled by the caller), then pushes
// back down to `base` so that every pixel there holds a normalised filled value with weight 1.
// Needs n > base >= 1; channels 1..8.
void pull_push_levels(std::vector<PullPushLevel>& levels, int n, int channels, PullFilter filter,
                      int base = 1);
// Size the pull-push levels for a width x height level 0; returns the number of levels.
int prepare_pull_push(std::vector<PullPushLevel>& levels, int width, int height, int channels);
// Bilinear lookup of a filled level 2^shift times coarser than the image (level `shift`) at fine
// pixel (x, y): coarse coordinate (x + 1/2) / 2^shift - 1/2 (on level 1 the weights are 3/4 and
// 1/4), edges clamped. Vertical first, then horizontal.
struct PullPushTaps {
  int i0, i1;  // coarse indices (clamped)
  float f;     // weight of i1
};
inline PullPushTaps pull_push_taps(int fine, int coarse_size, int shift = 1) {
  const int num = 2 * fine + 1 - (1 << shift);  // 2^(shift+1) times the coarse coordinate
  const int i0 = num >> (shift + 1);            // floor, also of the negative first half cell
  const float f = static_cast<float>(num & ((2 << shift) - 1)) / static_cast<float>(2 << shift);
  return {std::max(i0, 0), std::min(i0 + 1, coarse_size - 1), f};
}
template <int C>
inline void pull_push_sample(const PullPushLevel& l1, int x, int y, float* out, int shift = 1) {
  constexpr int stride = C + 1;
  const PullPushTaps tx = pull_push_taps(x, l1.width, shift),
                     ty = pull_push_taps(y, l1.height, shift);
  const float* r0 = l1.data.data() + static_cast<size_t>(ty.i0) * l1.width * stride;
  const float* r1 = l1.data.data() + static_cast<size_t>(ty.i1) * l1.width * stride;
  for (int k = 0; k < C; ++k) {
    float a = (1 - ty.f) * r0[tx.i0 * stride + k] + ty.f * r1[tx.i0 * stride + k];
    float b = (1 - ty.f) * r0[tx.i1 * stride + k] + ty.f * r1[tx.i1 * stride + k];
    out[k] = (1 - tx.f) * a + tx.f * b;
  }
}
// The same for the first four channels of pixels [xa, xb) of row y at once (identical values);
// `tmp` holds at least (xb - xa) / 2 + 3 entries.
inline void pull_push_sample_row(const PullPushLevel& l1, int y, int xa, int xb, Rgba* out,
                                 Rgba* tmp, int shift = 1) {
  const PullPushTaps ty = pull_push_taps(y, l1.height, shift);
  const float* r0 = l1.data.data() + static_cast<size_t>(ty.i0) * l1.width * 5;
  const float* r1 = l1.data.data() + static_cast<size_t>(ty.i1) * l1.width * 5;
  const int ca = std::max((xa >> shift) - 1, 0),
            cb = std::min(((xb - 1) >> shift) + 1, l1.width - 1);
  const Float4 w0 = {1 - ty.f, 1 - ty.f, 1 - ty.f, 1 - ty.f}, w1 = {ty.f, ty.f, ty.f, ty.f};
  for (int c = ca; c <= cb; ++c) {
    Float4 a, b;
    std::memcpy(&a, r0 + 5 * c, sizeof a);
    std::memcpy(&b, r1 + 5 * c, sizeof b);
    tmp[c - ca] = as_rgba(w0 * a + w1 * b);
  }
  for (int x = xa; x < xb; ++x) {
    const PullPushTaps tx = pull_push_taps(x, l1.width, shift);
    out[x - xa] = as_rgba(as_vec(tmp[tx.i0 - ca]) * (1 - tx.f) + as_vec(tmp[tx.i1 - ca]) * tx.f);
  }
}
void pull_push_sample(const PullPushLevel& l1, int channels, int x, int y, float* out);

// ---- template implementation ---------------------------------------------------------------

template <class RowSource>
void reduce_box4_rows(int fine_width, int fine_height, const RgbaView& coarse, ScratchRows& scratch,
                      const Runs* fine_runs, const Runs* coarse_runs, const RowSource& src) {
  const int fw = fine_width, fh = fine_height, cw = coarse.width;
  parallel_rows(
      coarse.height,
      [&](int y0, int y1) {
        Rgba* tmp = scratch.get(0, fw + 3) + 1;  // tmp[-1], tmp[fw], tmp[fw+1] repeat the edges
        Rgba* ring[4];
        int tag[4] = {-1, -1, -1, -1};
        Span dirty[4];  // where the slot may hold non-zero pixels (the scratch is reused)
        for (int k = 0; k < 4; ++k) {
          ring[k] = scratch.get(2 + k, fw);
          dirty[k] = {0, fw};
        }
        auto fetch = [&](int fy) -> const Rgba* {
          int slot = fy & 3;  // rows 2y-1 .. 2y+2 of one coarse row never share a slot
          if (tag[slot] != fy) {
            const Runs& r = fine_runs[fy];
            r.zero_outside(ring[slot], dirty[slot].x0, dirty[slot].x1);
            for (const Span& s : r) src(fy, s.x0, s.x1, ring[slot]);
            dirty[slot] = r.bounds();
            tag[slot] = fy;
          }
          return ring[slot];
        };
        for (int y = y0; y < y1; ++y) {
          const Runs& runs = coarse_runs[y];
          if (runs.empty()) {  // its fine rows need not be produced
            zero_run(coarse.row(y), 0, cw);
            continue;
          }
          const Rgba* r0 = fetch(std::max(2 * y - 1, 0));
          const Rgba* r1 = fetch(std::min(2 * y, fh - 1));
          const Rgba* r2 = fetch(std::min(2 * y + 1, fh - 1));
          const Rgba* r3 = fetch(std::min(2 * y + 2, fh - 1));
          reduce_box4_row(r0, r1, r2, r3, tmp, fw, coarse.row(y), cw, runs);
        }
      },
      4);
}

template <class Store>
void expand_bspline2(const RgbaView& coarse, int fine_width, int fine_height, ScratchRows& scratch,
                     const Store& store, const Runs* runs) {
  constexpr float kNear = 22.0f / 32.0f, kFar = 9.0f / 32.0f, kOut = 1.0f / 32.0f;
  const int cw = coarse.width, ch = coarse.height;
  const Runs whole = Runs::whole(fine_width);
  parallel_rows(
      fine_height,
      [&](int y0, int y1) {
        Rgba* tmp = scratch.get(0, cw + 2) + 1;  // tmp[-1] and tmp[cw] repeat the edges
        Rgba* out = scratch.get(1, fine_width + 1);
        for (int y = y0; y < y1; ++y) {
          const Runs& row_runs = runs ? runs[y] : whole;
          const int m = y >> 1;
          const Rgba* rm = coarse.row(std::max(m - 1, 0));
          const Rgba* r0 = coarse.row(std::min(m, ch - 1));
          const Rgba* rp = coarse.row(std::min(m + 1, ch - 1));
          const float wm = (y & 1) ? kOut : kFar, wp = (y & 1) ? kFar : kOut;
          for (const Span& s : row_runs) {
            // Whole pairs of fine pixels, from the coarse pixels they see.
            const int xa = s.x0 & ~1, xb = std::min(s.x1 + (s.x1 & 1), fine_width);
            const int ta = std::max((xa >> 1) - 1, 0), tb = std::min(((xb - 1) >> 1) + 2, cw);
            for (int x = ta; x < tb; ++x) tmp[x] = rm[x] * wm + r0[x] * kNear + rp[x] * wp;
            if (ta == 0) tmp[-1] = tmp[0];
            if (tb == cw) tmp[cw] = tmp[cw - 1];
            const int pairs = xb >> 1;
            for (int k = xa >> 1; k < pairs; ++k) {
              out[2 * k] = tmp[k - 1] * kFar + tmp[k] * kNear + tmp[k + 1] * kOut;
              out[2 * k + 1] = tmp[k - 1] * kOut + tmp[k] * kNear + tmp[k + 1] * kFar;
            }
            if (xb & 1) {  // the last pixel of an odd width: then pairs = cw - 1, tmp[cw] the edge
              const int k = pairs;
              out[2 * k] = tmp[k - 1] * kFar + tmp[k] * kNear + tmp[k + 1] * kOut;
            }
          }
          store(y, static_cast<const Rgba*>(out), row_runs);
        }
      },
      2);
}

}  // namespace dofcache::preview::detail
