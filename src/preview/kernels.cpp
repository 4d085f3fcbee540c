#include "kernels.h"

#include <algorithm>
#include <cmath>
#include <type_traits>
#include <vector>

namespace dofcache::preview::detail {

void reduce_box4(const RgbaView& fine, const RgbaView& coarse, ScratchRows& scratch,
                 const Runs* runs) {
  const int fw = fine.width, fh = fine.height, cw = coarse.width;
  parallel_rows(
      coarse.height,
      [&](int y0, int y1) {
        Rgba* tmp = scratch.get(0, fw + 3) + 1;  // tmp[-1], tmp[fw], tmp[fw+1] repeat the edges
        for (int y = y0; y < y1; ++y) {
          reduce_box4_row(fine.row(std::max(2 * y - 1, 0)), fine.row(std::min(2 * y, fh - 1)),
                          fine.row(std::min(2 * y + 1, fh - 1)),
                          fine.row(std::min(2 * y + 2, fh - 1)), tmp, fw, coarse.row(y), cw,
                          runs ? runs[y] : Runs::whole(cw));
        }
      },
      2);
}

Runs unite(const Runs& a, const Runs& b) {
  Runs out;
  int i = 0, j = 0;
  while (i < a.n || j < b.n)
    out.append(j == b.n || (i < a.n && a.run[i].x0 <= b.run[j].x0) ? a.run[i++] : b.run[j++]);
  return out;
}

void reduce_runs(const Runs* fine, int fine_height, int coarse_width, int coarse_height,
                 std::vector<Runs>& coarse) {
  coarse.assign(coarse_height, Runs{});
  for (int y = 0; y < coarse_height; ++y) {
    const Runs u =
        unite(unite(fine[std::max(2 * y - 1, 0)], fine[std::min(2 * y, fine_height - 1)]),
              unite(fine[std::min(2 * y + 1, fine_height - 1)],
                    fine[std::min(2 * y + 2, fine_height - 1)]));
    // Coarse m sees fine 2m-1 .. 2m+2: some of [x0, x1) iff ceil(x0 / 2) - 1 <= m <= floor(x1 / 2).
    for (const Span& s : u)
      coarse[y].append({std::max((s.x0 + 1) / 2 - 1, 0), std::min(s.x1 / 2 + 1, coarse_width)});
  }
}

void expand_runs(const Runs* coarse, int coarse_height, int fine_width, int fine_height,
                 std::vector<Runs>& fine) {
  fine.assign(fine_height, Runs{});
  for (int y = 0; y < fine_height; ++y) {
    const int m = y >> 1;
    const Runs u = unite(unite(coarse[std::max(m - 1, 0)], coarse[std::min(m, coarse_height - 1)]),
                         coarse[std::min(m + 1, coarse_height - 1)]);
    // Fine x sees coarse x/2 - 1 .. x/2 + 1: some of [x0, x1) iff x0 - 1 <= x/2 <= x1.
    for (const Span& s : u)
      fine[y].append({std::max(2 * s.x0 - 2, 0), std::min(2 * s.x1 + 2, fine_width)});
  }
}

int prepare_pull_push(std::vector<PullPushLevel>& levels, int width, int height, int channels) {
  int n = 1;
  for (int w = width, h = height; w > 1 || h > 1; w = (w + 1) / 2, h = (h + 1) / 2) ++n;
  if (levels.size() < static_cast<size_t>(n)) levels.resize(n);
  int w = width, h = height;
  for (int l = 0; l < n; ++l) {
    levels[l].width = w;
    levels[l].height = h;
    if (l > 0) ensure_size(levels[l].data, static_cast<size_t>(w) * h * (channels + 1));
    w = (w + 1) / 2;
    h = (h + 1) / 2;
  }
  return n;
}

namespace {

// Weighted 2x2 reduce of level l into level l+1 (unpremultiplied values beside their weight).
template <int C>
void pull_level_box(const PullPushLevel& fine, PullPushLevel& coarse) {
  constexpr int s = C + 1;
  parallel_rows(
      coarse.height,
      [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y) {
          for (int x = 0; x < coarse.width; ++x) {
            float acc[C + 1] = {};
            for (int fy = 2 * y; fy < std::min(2 * y + 2, fine.height); ++fy)
              for (int fx = 2 * x; fx < std::min(2 * x + 2, fine.width); ++fx) {
                const float* p = fine.data.data() + (static_cast<size_t>(fy) * fine.width + fx) * s;
                float w = p[C];
                if (!(w > 0)) continue;
                for (int k = 0; k < C; ++k) acc[k] += w * p[k];
                acc[C] += w;
              }
            float* q = coarse.data.data() + (static_cast<size_t>(y) * coarse.width + x) * s;
            float inv = acc[C] > 0 ? 1.0f / acc[C] : 0.0f;
            for (int k = 0; k < C; ++k) q[k] = acc[k] * inv;
            q[C] = std::min(1.0f, acc[C]);
          }
        }
      },
      8);
}

// Weighted reduce of level l into level l+1 (unpremultiplied values beside their weight) with the
// overlapping 4x4 tent [1 3 3 1] / 4 per axis: a coarse cell also sees the fine cells just across
// its edges, so a hole's fill next to known pixels comes from them, not from a much coarser level
// (with a 2x2 box a hole whose edge falls on a cell boundary took its whole fill from far away).
// Separable: fine rows are premultiplied and reduced along x once each (a ring of four), then
// combined along y. Values of unknown cells (weight 0) are finite on levels >= 1, so they drop
// out by their zero weight without a branch.
template <int C>
void pull_level_tent(const PullPushLevel& fine, PullPushLevel& coarse) {
  constexpr int s = C + 1;
  constexpr float kOuter = 0.25f, kInner = 0.75f;
  const int cw = coarse.width, fw = fine.width, fh = fine.height;
  parallel_rows(
      coarse.height,
      [&](int y0, int y1) {
        std::vector<float> ring(static_cast<size_t>(4) * cw * s),
            pre(static_cast<size_t>(fw + 3) * s);
        // Fine row fy reduced along x into ring slot fy & 3 (zero outside the image).
        auto reduce_row = [&](int fy) {
          float* h = ring.data() + static_cast<size_t>(fy & 3) * cw * s;
          if (fy < 0 || fy >= fh) {
            std::fill(h, h + static_cast<size_t>(cw) * s, 0.0f);
            return;
          }
          const float* src = fine.data.data() + static_cast<size_t>(fy) * fw * s;
          float* pp = pre.data();  // pp[i + 1] = fine cell i premultiplied; zeros around
          std::fill(pp, pp + s, 0.0f);
          for (int i = 0; i < fw; ++i) {
            const float* v = src + static_cast<size_t>(i) * s;
            float* o = pp + static_cast<size_t>(i + 1) * s;
            for (int c = 0; c < C; ++c) o[c] = v[C] * v[c];
            o[C] = v[C];
          }
          std::fill(pp + static_cast<size_t>(fw + 1) * s, pp + static_cast<size_t>(fw + 3) * s,
                    0.0f);
          for (int x = 0; x < cw; ++x) {
            const float* t = pp + static_cast<size_t>(2 * x) * s;
            float* q = h + static_cast<size_t>(x) * s;
            for (int c = 0; c < s; ++c)
              q[c] = kOuter * (t[c] + t[3 * s + c]) + kInner * (t[s + c] + t[2 * s + c]);
          }
        };
        reduce_row(2 * y0 - 1);
        reduce_row(2 * y0);
        for (int y = y0; y < y1; ++y) {
          reduce_row(2 * y + 1);
          reduce_row(2 * y + 2);
          const float* r[4];
          for (int t = 0; t < 4; ++t)
            r[t] = ring.data() + static_cast<size_t>((2 * y - 1 + t) & 3) * cw * s;
          for (int x = 0; x < cw; ++x) {
            const size_t o = static_cast<size_t>(x) * s;
            float acc[s];
            for (int c = 0; c < s; ++c)
              acc[c] = kOuter * (r[0][o + c] + r[3][o + c]) + kInner * (r[1][o + c] + r[2][o + c]);
            float* q = coarse.data.data() + (static_cast<size_t>(y) * cw + x) * s;
            const float inv = acc[C] > 0 ? 1.0f / acc[C] : 0.0f;
            for (int c = 0; c < C; ++c) q[c] = acc[c] * inv;
            q[C] = std::min(1.0f, acc[C]);
          }
        }
      },
      8);
}

// Fills level l from the filled level l+1 where its weight is below one.
template <int C>
void push_level(PullPushLevel& fine, const PullPushLevel& coarse) {
  constexpr int s = C + 1;
  parallel_rows(
      fine.height,
      [&](int y0, int y1) {
        float interp[C];
        for (int y = y0; y < y1; ++y) {
          for (int x = 0; x < fine.width; ++x) {
            float* p = fine.data.data() + (static_cast<size_t>(y) * fine.width + x) * s;
            float w = p[C];
            if (w >= 1) continue;
            pull_push_sample<C>(coarse, x, y, interp);
            if (w <= 0) {
              for (int k = 0; k < C; ++k) p[k] = interp[k];
            } else {
              for (int k = 0; k < C; ++k) p[k] = w * p[k] + (1 - w) * interp[k];
            }
            p[C] = 1;
          }
        }
      },
      8);
}

template <int C>
void pull_push_levels_c(std::vector<PullPushLevel>& levels, int n, PullFilter filter, int base) {
  for (int l = base; l + 1 < n; ++l) {
    if (filter == PullFilter::Tent)
      pull_level_tent<C>(levels[l], levels[l + 1]);
    else
      pull_level_box<C>(levels[l], levels[l + 1]);
  }
  // The top (1x1) is normalised already; weight 0 there means nothing was known: value 0.
  float* p = levels[n - 1].data.data();
  if (!(p[C] > 0))
    for (int k = 0; k < C; ++k) p[k] = 0;
  p[C] = 1;
  for (int l = n - 2; l >= base; --l) push_level<C>(levels[l], levels[l + 1]);
}

template <class F>
void dispatch_channels(int channels, const F& f) {
  switch (channels) {
    case 1:
      f(std::integral_constant<int, 1>{});
      break;
    case 2:
      f(std::integral_constant<int, 2>{});
      break;
    case 3:
      f(std::integral_constant<int, 3>{});
      break;
    case 4:
      f(std::integral_constant<int, 4>{});
      break;
    case 5:
      f(std::integral_constant<int, 5>{});
      break;
    case 6:
      f(std::integral_constant<int, 6>{});
      break;
    case 7:
      f(std::integral_constant<int, 7>{});
      break;
    case 8:
      f(std::integral_constant<int, 8>{});
      break;
    default:
      break;
  }
}

}  // namespace

void pull_push_levels(std::vector<PullPushLevel>& levels, int n, int channels, PullFilter filter,
                      int base) {
  dispatch_channels(
      channels, [&](auto c) { pull_push_levels_c<decltype(c)::value>(levels, n, filter, base); });
}

void pull_push_sample(const PullPushLevel& l1, int channels, int x, int y, float* out) {
  dispatch_channels(channels, [&](auto c) { pull_push_sample<decltype(c)::value>(l1, x, y, out); });
}

}  // namespace dofcache::preview::detail
