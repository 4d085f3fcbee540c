#include "kernels.h"

#include <cmath>
#include <type_traits>

namespace dofcache::preview::detail {

void reduce_box4(const RgbaView& fine, const RgbaView& coarse, ScratchRows& scratch) {
  const int fw = fine.width, fh = fine.height, cw = coarse.width;
  parallel_rows(
      coarse.height,
      [&](int y0, int y1) {
        Rgba* tmp = scratch.get(0, fw + 3) + 1;  // tmp[-1], tmp[fw], tmp[fw+1] repeat the edges
        for (int y = y0; y < y1; ++y) {
          reduce_box4_row(fine.row(std::max(2 * y - 1, 0)), fine.row(std::min(2 * y, fh - 1)),
                          fine.row(std::min(2 * y + 1, fh - 1)),
                          fine.row(std::min(2 * y + 2, fh - 1)), tmp, fw, coarse.row(y), cw);
        }
      },
      2);
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
void pull_level(const PullPushLevel& fine, PullPushLevel& coarse) {
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
void pull_push_levels_c(std::vector<PullPushLevel>& levels, int n) {
  for (int l = 1; l + 1 < n; ++l) pull_level<C>(levels[l], levels[l + 1]);
  // The top (1x1) is normalised already; weight 0 there means nothing was known: value 0.
  float* p = levels[n - 1].data.data();
  if (!(p[C] > 0))
    for (int k = 0; k < C; ++k) p[k] = 0;
  p[C] = 1;
  for (int l = n - 2; l >= 1; --l) push_level<C>(levels[l], levels[l + 1]);
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

void pull_push_levels(std::vector<PullPushLevel>& levels, int n, int channels) {
  dispatch_channels(channels, [&](auto c) { pull_push_levels_c<decltype(c)::value>(levels, n); });
}

void pull_push_sample(const PullPushLevel& l1, int channels, int x, int y, float* out) {
  dispatch_channels(channels, [&](auto c) { pull_push_sample<decltype(c)::value>(l1, x, y, out); });
}

}  // namespace dofcache::preview::detail
