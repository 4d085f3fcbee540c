// The occlusion fix's edge trace: near occluding edges the lens integral is evaluated directly by
// tracing lens rays through the layered depth image the preview already holds (the pinhole surface
// and the revealed fragments), and the result replaces the layer composite there.
//
// Why: layers blur each depth slab over the whole lens and composite the slabs with one alpha per
// pixel, so a pixel that sees a foreground edge through part of its lens sees the *whole* disk of
// the background behind it, attenuated. The lens sees only the part of the background that the
// unoccluded part of the lens looks at (partial visibility). Where the background behind an edge is
// not uniform (a bar behind a bar, the ball behind a bar) that is what keeps the layered fix's edge
// error high; exact visibility through the same inputs has a third of it (docs/preview.md).
//
// Geometry (the lens-reach rule of occlusion.h): the ray through pixel centre p and lens point u
// (unit disk) crosses the depth of signed CoC c at p + u c / 2 (eq. (2.6): the CoC radius is
// c / 2). Along the ray c increases from the lens outwards, so the first fragment met is the one
// seen.
//
// Cost control:
//  * only the pixels whose lens rays can pass an occluding edge are traced (within the nearer
//    side's CoC radius of 4-neighbours whose CoC differ by more than 1 px:
//    partial_occlusion_radius), with a feather outside it;
//  * a ray is not marched in fixed steps: the CoC range is cut into 64 bins, every pixel holds a
//    64-bit mask of the bins its fragments occupy, and a ray visits only the bins that some pixel
//    within that bin's reach occupies (4x4-pixel tiles), one lookup each: 1.7 lookups per ray on
//    the demo scene, 2.8 on colour bars (exact per-pixel bin reach would save only 15 %); where a
//    ray meets a bin is a whole-pixel step that does not depend on the pixel, tabled per frame;
//  * four rim rays probe first, and a pixel whose probes all meet its own surface keeps the
//    composite; rays stop at their first hit.
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <type_traits>

#include "dofcache/lens/thin_lens.h"
#include "pipeline.h"

namespace dofcache::preview::detail {
namespace {

constexpr int kBins = 64;
constexpr int kTile = 4;                  // tiles of the reach masks
constexpr float kFeather = 1.0f;          // pixels outside the band over which the trace fades out
constexpr float kNotNear = -1e30f;        // band reach of a pixel no edge reaches
constexpr int kRotations = 97;            // distinct rotations of the lens grid over the image
constexpr int kFloorOffsetInt = 1 << 12;  // > the largest CoC radius (clamped to 128 px)
constexpr float kFloorOffset = static_cast<float>(kFloorOffsetInt);
constexpr float kEdgeJump = kOccludingEdgeJump;  // CoC jump of an occluding edge (layers.h)

// 64 equal bins over the signed CoC range of the fragments. Thin bins keep the fragments thin, so a
// ray passes behind a foreground edge as closely as the lens lets it (bins of at least 1 px, the
// thickness of a plain march, lose most of the gain on colour bars at 160x120, where the whole
// range is 11 px). While a ray crosses one bin it moves at most w / 2 pixels.
struct Bins {
  float lo = 0, width = 1, inv_width = 1;
  int of(float c) const {
    const int b = static_cast<int>((c - lo) * inv_width);
    return std::clamp(b, 0, kBins - 1);
  }
  float centre(int b) const { return lo + (static_cast<float>(b) + 0.5f) * width; }
};

// Sets every flag within r of a set one (a (2r + 1) x (2r + 1) square), in O(1) per flag.
void dilate_flags(std::vector<unsigned char>& f, int w, int h, int r) {
  std::vector<unsigned char> rows(f.size());
  std::vector<int> count(std::max(w, h) + 1);
  for (int y = 0; y < h; ++y) {
    const unsigned char* src = f.data() + static_cast<size_t>(y) * w;
    for (int x = 0; x < w; ++x) count[x + 1] = count[x] + src[x];
    for (int x = 0; x < w; ++x)
      rows[static_cast<size_t>(y) * w + x] =
          count[std::min(w, x + r + 1)] - count[std::max(0, x - r)] > 0;
  }
  for (int x = 0; x < w; ++x) {
    for (int y = 0; y < h; ++y) count[y + 1] = count[y] + rows[static_cast<size_t>(y) * w + x];
    for (int y = 0; y < h; ++y)
      f[static_cast<size_t>(y) * w + x] =
          count[std::min(h, y + r + 1)] - count[std::max(0, y - r)] > 0;
  }
}

// How far from an occluding edge between 4-neighbours of signed CoC a and b (0: none) a pixel's
// lens rays can pass the nearer side's boundary: at the nearer side's depth (CoC min(a, b)) the
// rays of a pixel spread over that CoC's radius (eq. (2.6)) around it. Farther away either every
// ray meets the nearer surface or none does, and behind it every ray sees the same surface through
// the whole lens, which the layers (with the revealed fill) blur correctly. This is narrower than
// the error band's occluding_edge_radius (max(|a|, |b|) / 2) where the farther side is the more
// defocused: a sharp foreground before a blurred background has no partial occlusion around it.
inline float partial_occlusion_radius(float a, float b) {
  const float r = std::max(1.0f, 0.5f * std::abs(std::min(a, b)));
  return std::abs(a - b) > kEdgeJump ? r : 0.0f;
}

// reach[p] = max over edge pixels q of (R_q - |p - q|), R_q the edge radius at q: >= 0 inside the
// union of the edge disks, minus the distance to its border outside. The best edge pixel (seed) is
// searched on 2x2 blocks like a distance transform propagates: each block offers its seed to the
// next along the rows (both ways), then along the columns (both ways), and keeps the better one at
// its centre. Each pixel then measures its block's seed exactly. A pixel can miss its best seed by
// about a pixel, which the feather absorbs. Reaches below `floor` (outside the feather) may be
// reported as kNotNear.
void edge_reach(const float* coc, int W, int H, float max_radius, float floor,
                std::vector<EdgeSeed>& seeds, std::vector<float>& reach) {
  const int BW = (W + 1) / 2, BH = (H + 1) / 2;
  ensure_size(seeds, static_cast<size_t>(BW) * BH);
  ensure_size(reach, static_cast<size_t>(W) * H);
  // The seed's reach at (x, y).
  auto value = [](const EdgeSeed& e, float x, float y) {
    return e.r > 0 ? e.r - std::sqrt((e.x - x) * (e.x - x) + (e.y - y) * (e.y - y)) : kNotNear;
  };
  auto centre = [](int b) { return 2.0f * static_cast<float>(b) + 0.5f; };
  // Each block's own seed: its edge pixel of largest radius. The radii of a row are computed
  // first, without branches (a loop the compiler vectorises), then picked per block.
  parallel_rows(BH, [&](int by0, int by1) {
    std::vector<float> radii(2 * static_cast<size_t>(W));
    for (int by = by0; by < by1; ++by) {
      const int rows = std::min(2, H - 2 * by);
      for (int i = 0; i < rows; ++i) {
        const int y = 2 * by + i;
        const float* c = coc + static_cast<size_t>(y) * W;
        const float* up = y > 0 ? c - W : c;  // a pixel is no edge with itself
        const float* down = y + 1 < H ? c + W : c;
        float* r = radii.data() + static_cast<size_t>(i) * W;
        auto radius = [&](int x, float left, float right) {
          return std::min(max_radius, std::max(std::max(partial_occlusion_radius(c[x], left),
                                                        partial_occlusion_radius(c[x], right)),
                                               std::max(partial_occlusion_radius(c[x], up[x]),
                                                        partial_occlusion_radius(c[x], down[x]))));
        };
        r[0] = radius(0, c[0], c[std::min(1, W - 1)]);
        for (int x = 1; x + 1 < W; ++x) r[x] = radius(x, c[x - 1], c[x + 1]);
        if (W > 1) r[W - 1] = radius(W - 1, c[W - 2], c[W - 1]);
      }
      for (int bx = 0; bx < BW; ++bx) {
        EdgeSeed best{0, 0, 0, kNotNear};
        for (int i = 0; i < rows; ++i)
          for (int x = 2 * bx; x < std::min(W, 2 * bx + 2); ++x) {
            const float r = radii[static_cast<size_t>(i) * W + x];
            if (r > best.r) best = {static_cast<float>(x), static_cast<float>(2 * by + i), r, 0};
          }
        best.reach = value(best, centre(bx), centre(by));
        seeds[static_cast<size_t>(by) * BW + bx] = best;
      }
    }
  });
  // Block b takes the seed of block `from` if that one reaches farther at b's centre. Each block
  // keeps its seed's reach there, so a step measures one distance. A seed's reach only falls along
  // the passes (each carries it away from its edge pixel), so once it is below `cut` at a block it
  // is dropped there: it could not bring any pixel it reaches from there above `floor`.
  const float cut = floor - 1.0f;
  auto relax = [&](int bx, int by, int fx, int fy) {
    const EdgeSeed& theirs = seeds[static_cast<size_t>(fy) * BW + fx];
    if (theirs.r <= 0) return;
    EdgeSeed& mine = seeds[static_cast<size_t>(by) * BW + bx];
    const float v = value(theirs, centre(bx), centre(by));
    if (v > mine.reach)
      mine = v < cut ? EdgeSeed{0, 0, 0, kNotNear} : EdgeSeed{theirs.x, theirs.y, theirs.r, v};
  };
  // Along the rows, a few rows side by side: each row is a chain of dependent steps, and
  // interleaving rows lets the processor overlap them.
  constexpr int kRows = 4;
  parallel_rows(BH, [&](int by0, int by1) {
    for (int b0 = by0; b0 < by1; b0 += kRows) {
      const int b1 = std::min(by1, b0 + kRows);
      for (int bx = 1; bx < BW; ++bx)
        for (int by = b0; by < b1; ++by) relax(bx, by, bx - 1, by);
      for (int bx = BW - 2; bx >= 0; --bx)
        for (int by = b0; by < b1; ++by) relax(bx, by, bx + 1, by);
    }
  });
  constexpr int kColumns = 16;  // columns per task: rows of a column block stay in cache
  tbb::parallel_for(0, (BW + kColumns - 1) / kColumns, [&](int k) {
    const int bx0 = k * kColumns, bx1 = std::min(BW, bx0 + kColumns);
    for (int by = 1; by < BH; ++by)
      for (int bx = bx0; bx < bx1; ++bx) relax(bx, by, bx, by - 1);
    for (int by = BH - 2; by >= 0; --by)
      for (int bx = bx0; bx < bx1; ++bx) relax(bx, by, bx, by + 1);
  });
  // A block whose seed reaches less than `floor` - 1 at its centre leaves it at every pixel
  // (they lie within 0.71 of the centre): no distance is measured there.
  parallel_rows(H, [&](int y0, int y1) {
    for (int y = y0; y < y1; ++y)
      for (int x = 0; x < W; ++x) {
        const EdgeSeed& seed = seeds[static_cast<size_t>(y / 2) * BW + x / 2];
        reach[static_cast<size_t>(y) * W + x] =
            seed.reach < cut ? kNotNear : value(seed, static_cast<float>(x), static_cast<float>(y));
      }
  });
}

}  // namespace

long trace_edge_band(const PreviewOptions& options, const LayerPlan& plan, int W, int H,
                     PreviewWorkspace::Impl& ws, image::Image& out) {
  // A 1x1 grid would be the pinhole ray alone, which the probes below (the grid's corners) would
  // always discard: fewer than 4 rays trace nothing.
  const int grid = static_cast<int>(std::lround(std::sqrt(std::max(0, options.edge_rays))));
  if (grid < 2 || W <= 0 || H <= 0) return 0;
  const size_t N = static_cast<size_t>(W) * H;
  const Rgba* px = ws.packed.data();
  // The layered pipeline has indexed the revealed fragments (ws.revealed_first, revealed_bits;
  // pixels without any have no bits set).
  const size_t fragment_count = ws.revealed_count;

  // The CoC range of every fragment (the plan holds the pinhole's), and its bins.
  float lo = static_cast<float>(plan.coc_min), hi = static_cast<float>(plan.coc_max);
  for (size_t k = 0; k < fragment_count; ++k)
    lo = std::min(lo, ws.revealed[k].a), hi = std::max(hi, ws.revealed[k].a);
  Bins bins;
  bins.lo = lo;
  bins.width = std::max(1e-3f, (hi - lo) * (1.0f + 1e-6f) / kBins);
  bins.inv_width = 1.0f / bins.width;

  // The band: pixels with reach > -kFeather are traced.
  std::vector<float>& reach = ws.trace_reach;
  edge_reach(ws.coc.data(), W, H, static_cast<float>(options.max_coc_radius), -kFeather,
             ws.trace_seeds, reach);

  // Bins occupied per fragment. A fragment spans its CoC and, if a 4-neighbour of the same
  // surface lies behind it (nearer than the edge threshold), back to that neighbour: continuous
  // surfaces stay closed to rays at any slope, while occluding edges stay thin.
  auto run = [&](float c, float back) {
    const int a = bins.of(c), b = bins.of(c + back);
    const std::uint64_t upto = b >= 63 ? ~std::uint64_t{0} : (std::uint64_t{2} << b) - 1;
    return upto & ~((std::uint64_t{1} << a) - 1);
  };
  auto extend = [](float back, float c, float nb) {  // back >= 0; without a branch
    const float d = nb - c;
    return std::max(back, d <= kEdgeJump ? d : 0.0f);
  };
  // A ray meets bin k within |c_k| / 2 + 1/2 of its pixel (its step, rounded to a pixel): the
  // bin's reach in tiles.
  const int tw = (W + kTile - 1) / kTile, th = (H + kTile - 1) / kTile;
  auto reach_of = [&](int k) {
    return static_cast<int>(std::ceil((0.5f * std::abs(bins.centre(k)) + 0.5f) / kTile));
  };
  int max_reach = 0;
  for (int k = 0; k < kBins; ++k) max_reach = std::max(max_reach, reach_of(k));
  // Rays land only in tiles within max_reach of the band's: occupancy is needed only there
  // (about half the tiles on the shipped scenes).
  std::vector<unsigned char> needed(static_cast<size_t>(tw) * th, 0);
  parallel_rows(th, [&](int ty0, int ty1) {
    for (int ty = ty0; ty < ty1; ++ty) {
      unsigned char* t = needed.data() + static_cast<size_t>(ty) * tw;
      for (int y = ty * kTile; y < std::min(H, (ty + 1) * kTile); ++y)
        for (int x = 0; x < W; ++x)
          t[x / kTile] |= reach[static_cast<size_t>(y) * W + x] > -kFeather;
    }
  });
  dilate_flags(needed, tw, th, max_reach);

  ensure_size(ws.trace_bins, 2 * N + fragment_count);
  // Per pixel {every fragment's bins, the pinhole fragment's bins} side by side (a ray reads
  // both), then one entry per revealed fragment.
  std::uint64_t* occ = ws.trace_bins.data();
  std::uint64_t* frag_run = occ + 2 * N;
  // ... and per tile, the union of its pixels' bins (each task owns whole tile rows).
  std::vector<std::uint64_t> tiles(static_cast<size_t>(tw) * th, 0), tmp(tiles.size(), 0);
  const float* coc = ws.coc.data();  // px[p].a, contiguous
  parallel_rows(
      th,
      [&](int ty0, int ty1) {
        for (int y = ty0 * kTile; y < std::min(H, ty1 * kTile); ++y) {
          const size_t row = static_cast<size_t>(y) * W;
          const size_t up = y > 0 ? row - W : row, down = y + 1 < H ? row + W : row;
          std::uint64_t* tile_row = tiles.data() + static_cast<size_t>(y / kTile) * tw;
          // Over runs of needed tiles: the pinhole fragments first, a loop without branches; then
          // the revealed ones.
          const unsigned char* need = needed.data() + static_cast<size_t>(y / kTile) * tw;
          for (int t0 = 0; t0 < tw;) {
            if (!need[t0]) {
              ++t0;
              continue;
            }
            int t1 = t0;
            while (t1 < tw && need[t1]) ++t1;
            const int xa = t0 * kTile, xb = std::min(W, t1 * kTile);
            t0 = t1;
            for (int x = xa; x < xb; ++x) {
              const size_t p = row + x;
              const float c = coc[p];
              float back = 0;
              back = extend(back, c, coc[row + std::max(x - 1, 0)]);
              back = extend(back, c, coc[row + std::min(x + 1, W - 1)]);
              back = extend(back, c, coc[up + x]);
              back = extend(back, c, coc[down + x]);
              occ[2 * p + 1] = run(c, back);
            }
            for (int x = xa; x < xb; ++x) {
              const size_t p = row + x;
              std::uint64_t m = occ[2 * p + 1];
              int k = ws.revealed_first[p];
              for (std::uint64_t b = ws.revealed_bits[p]; b; b &= b - 1, ++k) {
                const size_t nbs[4] = {x > 0 ? p - 1 : p, x + 1 < W ? p + 1 : p, up + x, down + x};
                const int j = ctz64(b);
                const float fc = ws.revealed[k].a;
                float fback = 0;
                for (size_t q : nbs) {
                  fback = extend(fback, fc, coc[q]);
                  const int g = ws.fragment_of_layer(q, j);
                  if (g >= 0) fback = extend(fback, fc, ws.revealed[g].a);
                }
                frag_run[k] = run(fc, fback);
                m |= frag_run[k];
              }
              occ[2 * p] = m;
              tile_row[x / kTile] |= m;
            }
          }
        }
      },
      1);
  // Bin k is met only within its reach: dilate each bin's tiles by it, one tile ring per step,
  // from the farthest-reaching bins in.
  std::vector<std::uint64_t> with_reach(max_reach + 1, 0);
  for (int k = 0; k < kBins; ++k) with_reach[reach_of(k)] |= std::uint64_t{1} << k;
  std::vector<std::uint64_t> dilated(tiles.size());
  for (size_t t = 0; t < tiles.size(); ++t) dilated[t] = tiles[t] & with_reach[max_reach];
  for (int r = max_reach; r > 0; --r) {  // a 3x3 dilation as two passes of 3
    parallel_rows(th, [&](int ty0, int ty1) {
      for (int ty = ty0; ty < ty1; ++ty) {
        const std::uint64_t* d = dilated.data() + static_cast<size_t>(ty) * tw;
        std::uint64_t* t = tmp.data() + static_cast<size_t>(ty) * tw;
        for (int tx = 0; tx < tw; ++tx)
          t[tx] = d[tx] | d[std::max(0, tx - 1)] | d[std::min(tw - 1, tx + 1)];
      }
    });
    parallel_rows(th, [&](int ty0, int ty1) {
      for (int ty = ty0; ty < ty1; ++ty) {
        const size_t row = static_cast<size_t>(ty) * tw;
        const size_t up = ty > 0 ? row - tw : row, down = ty + 1 < th ? row + tw : row;
        for (int tx = 0; tx < tw; ++tx)
          dilated[row + tx] =
              (tiles[row + tx] & with_reach[r - 1]) | tmp[row + tx] | tmp[up + tx] | tmp[down + tx];
      }
    });
  }
  tiles.swap(dilated);

  // A stratified grid on the lens, rotated per 2x2 pixels (a fixed golden-angle sequence) so that
  // its structure turns into noise rather than aliasing. Per 2x2 rather than per pixel: neighbours
  // that share the rays' steps land on neighbouring pixels, which the processor predicts and
  // caches better (6 % less trace time on colour bars at 640x480); the band's error is the same
  // within the pattern's own spread (docs/preview.md).
  std::vector<glm::vec2> lens;
  for (int a = 0; a < grid; ++a)
    for (int b = 0; b < grid; ++b)
      lens.push_back(lens::concentric_disk({(a + 0.5f) / grid, (b + 0.5f) / grid}));
  // Probes first: the four cells at the grid's corners, which map to the lens's rim on the
  // diagonals (the rays that see farthest past an edge).
  int probes = 0;
  for (int corner : {0, grid - 1, grid * (grid - 1), grid * grid - 1})
    std::swap(lens[probes++], lens[corner]);
  const float inv_rays = 1.0f / static_cast<float>(lens.size());
  // Where each ray meets each bin, as a whole-pixel step from the pixel it starts at: the ray
  // through pixel centre x + 1/2 and lens offset u / 2 crosses bin k at x + 1/2 + u c_k / 2, in
  // pixel x + floor(1/2 + u c_k / 2) whatever x is. Tabled per rotation, bin and ray (bin-major,
  // so a lookup is one load rather than the landing arithmetic).
  const int rays = static_cast<int>(lens.size());
  // Fewer rotations for very many rays keep the table small (at most about 1.6 MB).
  const int rotations = std::clamp(400000 / (kBins * rays), 1, kRotations);
  struct Step {
    std::int32_t offset;  // dy W + dx
    std::int16_t dx, dy;
  };
  std::vector<Step> steps(static_cast<size_t>(rotations) * kBins * rays);
  // Pixels at least the longest bin reach inside the image need no bounds checks.
  const int margin = max_reach * kTile;
  tbb::parallel_for(0, rotations, [&](int r) {
    const glm::vec2 rot{std::cos(2.3999632f * r), std::sin(2.3999632f * r)};
    for (int i = 0; i < rays; ++i) {
      const glm::vec2 l = lens[i];
      const glm::vec2 u{0.5f * (rot.x * l.x - rot.y * l.y), 0.5f * (rot.y * l.x + rot.x * l.y)};
      for (int k = 0; k < kBins; ++k) {  // floor() without a library call
        const float c = bins.centre(k);
        const int dx = static_cast<int>(0.5f + u.x * c + kFloorOffset) - kFloorOffsetInt;
        const int dy = static_cast<int>(0.5f + u.y * c + kFloorOffset) - kFloorOffsetInt;
        steps[(static_cast<size_t>(r) * kBins + k) * rays + i] = {
            dy * W + dx, static_cast<std::int16_t>(dx), static_cast<std::int16_t>(dy)};
      }
    }
  });

  // The first fragment along the ray from pixel (x, y) whose bin steps are s[k * rays], visiting
  // the bins in `visit`; null if it meets none.
  const std::uint64_t* const occupancy = occ;
  const int width = W, height = H;
  auto first_hit = [&, occupancy, width, height, rays](auto checked, int x, int y, size_t p,
                                                       const Step* s,
                                                       std::uint64_t visit) -> const Rgba* {
    for (std::uint64_t v = visit; v; v &= v - 1) {
      const int k = ctz64(v);
      const Step st = s[k * rays];
      if constexpr (decltype(checked)::value) {
        if (static_cast<unsigned>(x + st.dx) >= static_cast<unsigned>(width) ||
            static_cast<unsigned>(y + st.dy) >= static_cast<unsigned>(height))
          continue;
      }
      const size_t q = static_cast<size_t>(static_cast<std::ptrdiff_t>(p) + st.offset);
      const std::uint64_t bit = std::uint64_t{1} << k;
      if (!(occupancy[2 * q] & bit)) continue;
      // The pinhole surface is nearer than any fragment revealed behind it.
      if (occupancy[2 * q + 1] & bit) return &px[q];
      for (int g = ws.revealed_first[q], end = g + popcount64(ws.revealed_bits[q]); g < end; ++g)
        if (frag_run[g] & bit) return &ws.revealed[g];
    }
    return nullptr;
  };

  float* o = out.data().data();
  std::atomic<long> traced{0};
  parallel_rows(H, [&](int y0, int y1) {
    long band = 0;
    for (int y = y0; y < y1; ++y)
      for (int x = 0; x < W; ++x) {
        const size_t p = static_cast<size_t>(y) * W + x;
        if (reach[p] <= -kFeather) continue;
        const float weight = std::min(1.0f, 1.0f + reach[p] / kFeather);
        ++band;
        const std::uint64_t visit = tiles[(y / kTile) * tw + x / kTile];
        const int rotation = ((x >> 1) * 7 + (y >> 1) * 13) % rotations;
        const Step* s = steps.data() + static_cast<size_t>(rotation) * kBins * rays;
        const bool inside = x >= margin && x < W - margin && y >= margin && y < H - margin;
        float sum[3] = {0, 0, 0};
        bool own_surface_only = true;
        for (int i = 0; i < rays; ++i) {
          // The probes at the lens's rim (the first ones) all meeting the pixel's own surface
          // mean that the whole lens does: the layer composite blurs that surface like the lens.
          if (i == probes && own_surface_only) break;
          const Rgba* hit = inside ? first_hit(std::false_type{}, x, y, p, s + i, visit)
                                   : first_hit(std::true_type{}, x, y, p, s + i, visit);
          own_surface_only = own_surface_only && hit && std::abs(hit->a - px[p].a) <= kEdgeJump;
          const float* rgb = hit ? &hit->r : o + 3 * p;  // a miss keeps the layer composite
          sum[0] += rgb[0], sum[1] += rgb[1], sum[2] += rgb[2];
        }
        if (own_surface_only) continue;
        for (int ch = 0; ch < 3; ++ch)
          o[3 * p + ch] += weight * (sum[ch] * inv_rays - o[3 * p + ch]);
      }
    traced += band;
  });
  return traced.load();
}

}  // namespace dofcache::preview::detail
