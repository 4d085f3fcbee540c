// Scatter (forward-mapping) baseline: depth-binned disk splats through per-row difference
// buffers, bins composited far to near (see baselines.h).
#include <algorithm>
#include <cmath>

#include "pipeline.h"

namespace dofcache::preview::detail {

namespace {
constexpr int kBandRows = 8;
constexpr int kMaxBins = 128;
constexpr float kQuantum = 16.0f;  // splat radii are quantised to 1/16 px

// Half-width of the discrete disk {dx^2 + dy^2 <= (r + 1/2)^2} on row dy.
inline int half_width(float r2, int dy) {
  return static_cast<int>(std::sqrt(std::max(0.0f, r2 - static_cast<float>(dy * dy))));
}
}  // namespace

void scatter_preview(const image::Image& color, const PreviewOptions& options,
                     PreviewWorkspace::Impl& ws, image::Image& out) {
  const int W = color.width(), H = color.height();
  const size_t N = color.pixel_count();
  const float* col = color.data().data();
  const float* C = ws.coc.data();

  // Radii (quantised), bins and splat densities.
  float cmin = C[0], cmax = C[0];
  for (size_t p = 1; p < N; ++p) {
    cmin = std::min(cmin, C[p]);
    cmax = std::max(cmax, C[p]);
  }
  const double span = static_cast<double>(cmax) - cmin;
  const double bin_width = std::max({options.scatter_bin_width, span / (kMaxBins - 0.5), 1e-6});
  const int bins = std::min(kMaxBins, static_cast<int>(span / bin_width) + 1);
  ensure_size(ws.radius, N);
  ensure_size(ws.inv_area, N);
  std::vector<int>& bin_of = ws.bin_pixels;  // reused below for the sorted pixel list
  ensure_size(bin_of, 2 * N);
  int* bin_index = bin_of.data() + N;
  float max_radius = 0;
  for (size_t p = 0; p < N; ++p) {
    float r = 0.5f * std::abs(C[p]);
    r = r > 0.5f ? std::round(r * kQuantum) / kQuantum : 0.0f;
    ws.radius[p] = r;
    max_radius = std::max(max_radius, r);
    bin_index[p] = std::min(bins - 1, static_cast<int>((C[p] - cmin) / bin_width));
  }
  // Pixel count of the discrete disk per quantised radius.
  const int quanta = static_cast<int>(max_radius * kQuantum) + 1;
  std::vector<float> inv_count(quanta);
  for (int k = 0; k < quanta; ++k) {
    float r = k / kQuantum, r2 = (r + 0.5f) * (r + 0.5f);
    int e = static_cast<int>(r + 0.5f), count = 0;
    for (int dy = -e; dy <= e; ++dy) count += 2 * half_width(r2, dy) + 1;
    inv_count[k] = 1.0f / count;
  }
  parallel_rows(H, [&](int y0, int y1) {
    for (int y = y0; y < y1; ++y)
      for (int x = 0; x < W; ++x) {
        size_t p = static_cast<size_t>(y) * W + x;
        float r = ws.radius[p];
        int e = static_cast<int>(r + 0.5f);
        if (x >= e && y >= e && x + e < W && y + e < H) {
          ws.inv_area[p] = inv_count[static_cast<int>(r * kQuantum + 0.5f)];
          continue;
        }
        // Near the border: normalise over the part of the disk inside the image, so a splat
        // keeps its full weight (and its bin its full coverage) up to the edge.
        float r2 = (r + 0.5f) * (r + 0.5f);
        int count = 0;
        for (int dy = std::max(-e, -y); dy <= std::min(e, H - 1 - y); ++dy) {
          int hw = half_width(r2, dy);
          count += std::min(x + hw, W - 1) - std::max(x - hw, 0) + 1;
        }
        ws.inv_area[p] = 1.0f / count;
      }
  });
  // Counting sort by bin; within a bin pixels stay in scan order (sorted by row).
  ws.bin_start.assign(bins + 1, 0);
  for (size_t p = 0; p < N; ++p) ++ws.bin_start[bin_index[p] + 1];
  for (int b = 0; b < bins; ++b) ws.bin_start[b + 1] += ws.bin_start[b];
  {
    std::vector<int> cursor(ws.bin_start.begin(), ws.bin_start.end() - 1);
    for (size_t p = 0; p < N; ++p) bin_of[cursor[bin_index[p]]++] = static_cast<int>(p);
  }
  const int* sorted = bin_of.data();

  ensure_size(ws.acc, N);
  std::fill(ws.acc.begin(), ws.acc.begin() + N, Rgba{0, 0, 0, 0});
  const size_t row_len = static_cast<size_t>(W + 1) * 4;
  ensure_size(ws.diff, row_len * H);
  const int bands = (H + kBandRows - 1) / kBandRows;

  // Per bin: the largest splat extent and the rows its splats can touch.
  std::vector<int> bin_extent(bins, 0);
  for (int b = 0; b < bins; ++b)
    for (int k = ws.bin_start[b]; k < ws.bin_start[b + 1]; ++k)
      bin_extent[b] = std::max(bin_extent[b], static_cast<int>(ws.radius[sorted[k]] + 0.5f));

  // Bands of rows are independent (each owns its rows of the difference buffer and of the
  // composite), so they run in parallel, each going through the bins far to near.
  tbb::parallel_for(
      tbb::blocked_range<int>(0, bands, 1), [&](const tbb::blocked_range<int>& range) {
        for (int band = range.begin(); band < range.end(); ++band) {
          const int r0 = band * kBandRows, r1 = std::min(H, (band + 1) * kBandRows);
          double* diff = ws.diff.data() + row_len * r0;
          for (int b = bins - 1; b >= 0; --b) {  // far to near
            const int begin = ws.bin_start[b], end = ws.bin_start[b + 1];
            if (begin == end) continue;
            const int e_max = bin_extent[b];
            // Sources whose disks can touch rows [r0, r1).
            const int* first =
                std::lower_bound(sorted + begin, sorted + end, std::max(0, r0 - e_max) * W);
            const int* last =
                std::lower_bound(sorted + begin, sorted + end, std::min(H, r1 + e_max) * W);
            if (first == last) continue;
            std::fill(diff, diff + row_len * (r1 - r0), 0.0);
            int ya = r1, yb = r0;  // rows this bin touches in the band
            for (const int* s = first; s < last; ++s) {
              const int q = *s, qy = q / W, qx = q % W;
              const float r = ws.radius[q], r2 = (r + 0.5f) * (r + 0.5f);
              const int e = static_cast<int>(r + 0.5f);
              const int dy0 = std::max(-e, r0 - qy), dy1 = std::min(e, r1 - 1 - qy);
              if (dy0 > dy1) continue;
              ya = std::min(ya, qy + dy0);
              yb = std::max(yb, qy + dy1 + 1);
              const double ia = ws.inv_area[q];
              const double v[4] = {col[3 * q] * ia, col[3 * q + 1] * ia, col[3 * q + 2] * ia, ia};
              for (int dy = dy0; dy <= dy1; ++dy) {
                const int hw = half_width(r2, dy);
                double* row = diff + row_len * (qy + dy - r0);
                double* a = row + 4 * std::max(qx - hw, 0);
                double* z = row + 4 * (std::min(qx + hw, W - 1) + 1);
                for (int k = 0; k < 4; ++k) {
                  a[k] += v[k];
                  z[k] -= v[k];
                }
              }
            }
            // Prefix sums give the bin's splat sums; composite them over what lies behind.
            for (int y = ya; y < yb; ++y) {
              const double* row = diff + row_len * (y - r0);
              Rgba* accrow = ws.acc.data() + static_cast<size_t>(y) * W;
              double sum[4] = {0, 0, 0, 0};
              for (int x = 0; x < W; ++x) {
                for (int k = 0; k < 4; ++k) sum[k] += row[4 * x + k];
                if (sum[3] <= 1e-9) continue;
                const float alpha = static_cast<float>(std::min(1.0, sum[3]));
                const double scale = alpha / sum[3];
                Rgba src{static_cast<float>(sum[0] * scale), static_cast<float>(sum[1] * scale),
                         static_cast<float>(sum[2] * scale), alpha};
                accrow[x] = src + accrow[x] * (1.0f - alpha);
              }
            }
          }
        }
      });

  float* o = out.data().data();
  parallel_rows(H, [&](int y0, int y1) {
    for (size_t p = static_cast<size_t>(y0) * W; p < static_cast<size_t>(y1) * W; ++p) {
      const Rgba& a = ws.acc[p];
      float inv = a.a > 0 ? 1.0f / a.a : 0.0f;
      o[3 * p] = a.r * inv;
      o[3 * p + 1] = a.g * inv;
      o[3 * p + 2] = a.b * inv;
    }
  });
}

}  // namespace dofcache::preview::detail
