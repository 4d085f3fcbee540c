// Gather (reverse-mapping) baseline; the weights and the bleeding guard are described in
// baselines.h.
#include <algorithm>
#include <cmath>

#include "pipeline.h"

namespace dofcache::preview::detail {

namespace {
constexpr int kTile = 16;
constexpr float kPi = 3.14159265358979f;
}  // namespace

// Blur radius of every pixel (0 when the CoC is at most one pixel wide), its splat density, and
// the colour split into planes for the inner loops.
static void prepare_radii(const image::Image& color, PreviewWorkspace::Impl& ws) {
  const size_t N = color.pixel_count();
  const int W = color.width(), H = color.height();
  ensure_size(ws.radius, N);
  ensure_size(ws.inv_area, N);
  ensure_size(ws.plane_r, N);
  ensure_size(ws.plane_g, N);
  ensure_size(ws.plane_b, N);
  const float* c = color.data().data();
  parallel_rows(H, [&](int y0, int y1) {
    for (size_t p = static_cast<size_t>(y0) * W; p < static_cast<size_t>(y1) * W; ++p) {
      float r = 0.5f * std::abs(ws.coc[p]);
      r = r > 0.5f ? r : 0.0f;
      ws.radius[p] = r;
      ws.inv_area[p] = 1.0f / std::max(1.0f, kPi * (r + 0.5f) * (r + 0.5f));
      ws.plane_r[p] = c[3 * p];
      ws.plane_g[p] = c[3 * p + 1];
      ws.plane_b[p] = c[3 * p + 2];
    }
  });
}

void gather_preview(const image::Image& color, const PreviewOptions& /*options*/,
                    PreviewWorkspace::Impl& ws, image::Image& out) {
  const int W = color.width(), H = color.height();
  prepare_radii(color, ws);
  const float* R = ws.radius.data();
  const float* C = ws.coc.data();
  const float* IA = ws.inv_area.data();
  const float* PR = ws.plane_r.data();
  const float* PG = ws.plane_g.data();
  const float* PB = ws.plane_b.data();

  // Largest radius per 16x16 tile, then over every tile a neighbour's disk could reach from.
  const int tw = (W + kTile - 1) / kTile, th = (H + kTile - 1) / kTile;
  std::vector<float> tile(static_cast<size_t>(tw) * th, 0.0f);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      float& t = tile[static_cast<size_t>(y / kTile) * tw + x / kTile];
      t = std::max(t, R[static_cast<size_t>(y) * W + x]);
    }
  float global = 0;
  for (float t : tile) global = std::max(global, t);
  const int reach = static_cast<int>(std::ceil((global + 0.5f) / kTile));
  ensure_size(ws.tile_radius, tile.size());
  for (int ty = 0; ty < th; ++ty)
    for (int tx = 0; tx < tw; ++tx) {
      float m = 0;
      for (int sy = std::max(0, ty - reach); sy <= std::min(th - 1, ty + reach); ++sy)
        for (int sx = std::max(0, tx - reach); sx <= std::min(tw - 1, tx + reach); ++sx)
          m = std::max(m, tile[static_cast<size_t>(sy) * tw + sx]);
      ws.tile_radius[static_cast<size_t>(ty) * tw + tx] = m;
    }

  float* o = out.data().data();
  parallel_rows(
      H,
      [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y)
          for (int x = 0; x < W; ++x) {
            const size_t p = static_cast<size_t>(y) * W + x;
            const float search =
                ws.tile_radius[static_cast<size_t>(y / kTile) * tw + x / kTile] + 0.5f;
            const int e = static_cast<int>(search);
            const float cp = C[p], rp = R[p];
            float sr = 0, sg = 0, sb = 0, sw = 0;
            for (int dy = std::max(-e, -y); dy <= std::min(e, H - 1 - y); ++dy) {
              const float d2y = static_cast<float>(dy * dy);
              const int hw = static_cast<int>(std::sqrt(std::max(0.0f, search * search - d2y)));
              const int xa = std::max(x - hw, 0), xb = std::min(x + hw, W - 1);
              const size_t row = static_cast<size_t>(y + dy) * W;
              for (int qx = xa; qx <= xb; ++qx) {
                const size_t q = row + qx;
                const float dx = static_cast<float>(qx - x);
                const float d2 = dx * dx + d2y;
                const float rq = R[q];
                // Nearer neighbours reach with their own radius, the others within p's as well.
                const float reff = C[q] < cp ? rq : std::min(rq, rp);
                const float lim = reff + 0.5f;
                const float w = d2 <= lim * lim ? IA[q] : 0.0f;
                sr += w * PR[q];
                sg += w * PG[q];
                sb += w * PB[q];
                sw += w;
              }
            }
            const float inv = 1.0f / sw;  // sw > 0: p always reaches itself
            o[3 * p] = sr * inv;
            o[3 * p + 1] = sg * inv;
            o[3 * p + 2] = sb * inv;
          }
      },
      1);
}

}  // namespace dofcache::preview::detail
