#include "dofcache/preview/pull_push.h"

#include <cassert>
#include <vector>

#include "dofcache/core/error.h"
#include "kernels.h"

namespace dofcache::preview {

void pull_push_fill(image::Image& values, const image::Image& weight) {
  const int w = values.width(), h = values.height(), c = values.channels();
  if (weight.width() != w || weight.height() != h || weight.channels() != 1)
    throw Error("pull_push_fill: weight must be 1 channel of the values' size");
  if (c < 1 || c > 8) throw Error("pull_push_fill: 1 to 8 channels supported");
  if (values.empty()) return;
  float* v = values.data().data();
  const float* wt = weight.data().data();
  const int s = c + 1;

  if (w == 1 && h == 1) {  // the pixel is its own surrounding: kept if known at all, else 0
    if (!(wt[0] > 0))
      for (int k = 0; k < c; ++k) v[k] = 0.0f;
    return;
  }

  std::vector<detail::PullPushLevel> levels;
  const int n = detail::prepare_pull_push(levels, w, h, c);
  detail::PullPushLevel& l1 = levels[1];
  // Pull level 0 -> 1 straight from the image (weights clamped to [0, 1]).
  detail::parallel_rows(l1.height, [&](int y0, int y1) {
    float acc[9];
    for (int y = y0; y < y1; ++y)
      for (int x = 0; x < l1.width; ++x) {
        for (int k = 0; k <= c; ++k) acc[k] = 0;
        for (int fy = 2 * y; fy < std::min(2 * y + 2, h); ++fy)
          for (int fx = 2 * x; fx < std::min(2 * x + 2, w); ++fx) {
            size_t p = static_cast<size_t>(fy) * w + fx;
            float wp = std::min(wt[p], 1.0f);
            if (!(wp > 0)) continue;
            for (int k = 0; k < c; ++k) acc[k] += wp * v[p * c + k];
            acc[c] += wp;
          }
        float* q = l1.data.data() + (static_cast<size_t>(y) * l1.width + x) * s;
        float inv = acc[c] > 0 ? 1.0f / acc[c] : 0.0f;
        for (int k = 0; k < c; ++k) q[k] = acc[k] * inv;
        q[c] = std::min(1.0f, acc[c]);
      }
  });
  detail::pull_push_levels(levels, n, c, detail::PullFilter::Tent);
  // Push level 1 -> 0 where the weight is below one; known pixels are not touched.
  detail::parallel_rows(h, [&](int y0, int y1) {
    float interp[8];
    for (int y = y0; y < y1; ++y)
      for (int x = 0; x < w; ++x) {
        size_t p = static_cast<size_t>(y) * w + x;
        float wp = wt[p];
        if (wp >= 1) continue;
        detail::pull_push_sample(l1, c, x, y, interp);
        float* q = v + p * c;
        if (wp > 0) {
          for (int k = 0; k < c; ++k) q[k] = wp * q[k] + (1 - wp) * interp[k];
        } else {
          for (int k = 0; k < c; ++k) q[k] = interp[k];
        }
      }
  });
}

}  // namespace dofcache::preview
