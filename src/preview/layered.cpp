// The layered preview: culling, disocclusion (pull-push or revealed layers), matting, pyramid blur
// and back-to-front blending, one layer at a time (see preview.h and docs/preview.md).
//
// Cost control: per frame the pinhole colour and CoC are packed into one RGBA stream and
// summarised per 2x2 block and 4x4 cell (for the pull of the disocclusion) and per 16x16 tile. Per
// layer the tiles are classified (wholly behind the layer: skipped; nothing culled; wholly culled;
// mixed), the matted layer is produced row by row straight into the first pyramid reduce (it is
// never stored at full resolution), and the pyramid runs on the bounding box of the tiles whose
// matte can be non-zero, plus the kernel's reach; within it, each row of each level is computed
// only over its runs that can be non-zero (a layer that holds a few bars and the floor spans the
// whole image, but most of its pixels are zero: kernels.h, Runs).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <type_traits>

#include "dofcache/core/error.h"
#include "dofcache/preview/pyramid.h"
#include "matting_kernel.h"
#include "pipeline.h"

namespace dofcache::preview::detail {
namespace {

constexpr int kTile = 16;
constexpr int kMaxDirectBlurRadius = 24;  // the direct blur's reach is at most this many pixels
using Block = PreviewWorkspace::Impl::Block;
using Tile = PreviewWorkspace::Impl::Tile;

struct Box {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;  // [x0, x1) x [y0, y1)
  bool empty() const { return x0 >= x1 || y0 >= y1; }
};

// The blurred layer is non-zero at most 2^(L+2) - 4 pixels outside its matte (reducing to level L
// spreads by 2^(L+1) - 2, expanding back as much again). With this margin, aligned to the level-L
// grid, the cropped pyramid reads only zeros across its cut edges: the same result as uncropped.
Box crop_for(const Box& b, int top_level, int width, int height) {
  const int a = 1 << top_level, m = 4 * a + a;
  auto down = [&](int v) { return v <= 0 ? 0 : (v / a) * a; };
  auto up = [&](int v, int limit) { return std::min(limit, ((v + a - 1) / a) * a); };
  return {down(b.x0 - m), down(b.y0 - m), up(b.x1 + m, width), up(b.y1 + m, height)};
}

// f(std::integral_constant<int, R>) for the direct blur's usual radii (so that its tap loops
// unroll), f(std::integral_constant<int, 0>) for any other.
template <class F>
void with_radius(int R, const F& f) {
  switch (R) {
    case 1:
      return f(std::integral_constant<int, 1>{});
    case 2:
      return f(std::integral_constant<int, 2>{});
    case 3:
      return f(std::integral_constant<int, 3>{});
    default:
      return f(std::integral_constant<int, 0>{});
  }
}

// The summary of no pixels, to accumulate into: min and max start at +inf and -inf.
constexpr Block kNoPixels{{0, 0, 0, 0},
                          std::numeric_limits<float>::infinity(),
                          -std::numeric_limits<float>::infinity(),
                          0};

// {r, g, b, c} -> {r a, g a, b a, a}.
inline Rgba premultiply(const Rgba& v, float alpha) {
  Float4 r = as_vec(v) * alpha;
  r[3] = alpha;
  return as_rgba(r);
}

void grow(Box& into, const Box& b) {
  if (b.empty()) return;
  into = {std::min(into.x0, b.x0), std::min(into.y0, b.y0), std::max(into.x1, b.x1),
          std::max(into.y1, b.y1)};
}

// How a blurred layer joins its target: "over" the composite, or added to the pending slab.
struct Over {
  bool add;
  void operator()(Rgba& dst, const Rgba& src) const {
    dst = add ? dst + src : src + dst * (1.0f - src.a);
  }
};

// The layered pipeline of one frame over the workspace, as named stages (run() calls them in
// order): setup (the packed pixels, revealed fragments and block, cell and tile summaries), then
// per layer from back to front disocclude (culling and the pull-push fill) and matte_and_blur
// (tile classes, matting, blur, into the composite or the pending slab, which flush_pending
// composites), and last resolve (and the occlusion fix's edge trace). The members are the
// frame's state, named as the stages use them.
class LayeredComposite {
 public:
  LayeredComposite(const PreviewInputs& in, const PreviewOptions& options, const LayerPlan& plan,
                   bool occlusion, PreviewWorkspace::Impl& ws, image::Image& out,
                   PreviewTimings& timings)
      : in(in),
        options(options),
        plan(plan),
        ws(ws),
        out(out),
        timings(timings),
        W(in.color.width()),
        H(in.color.height()),
        N(static_cast<size_t>(W) * H),
        n(plan.size()),
        color(in.color.data().data()),
        occlusion(occlusion && !in.revealed.empty()),
        slabs(options.layer_composite == LayerComposite::Slabs),
        pending_box{W, H, 0, 0} {}

  void run() {
    timings.layers = n;
    setup();
    for (int i = n - 1; i >= 0; --i) {
      if (slabs) {
        // The far half completes the slab [c_i, c_{i+1}], which then goes over what lies behind it.
        // The slab's holes (c < c_i) are those of layer i+1, whose fill ws.pull_push still holds:
        // the far half backs them with it too, at the hat's weight of the fill's CoC, so a fill
        // next to a surface at c_i is blurred like that surface (see Matte::fill_weight).
        matte_and_blur(i, MattePart::FarHalf);
        flush_pending();
      }
      disocclude(i);
      matte_and_blur(i, slabs ? MattePart::NearHalf : MattePart::Trapezoid);
    }
    if (slabs) {
      flush_pending();
      // Set only here: a composite cut short by an exception leaves it false.
      ws.pending_zero = true;
    }
    resolve();
  }

 private:
  using clock = std::chrono::steady_clock;
  enum class TileClass : unsigned char { Skip, Kept, Culled, Mixed };
  static constexpr float kInf = std::numeric_limits<float>::infinity();

  // ---------------------------------------------------------------- setup (per frame)
  void setup() {
    auto t0 = clock::now();
    pack_pixels();
    pack_revealed();
    summarise();
    ensure_size(ws.acc, N);
    parallel_rows(H, [&](int y0, int y1) {
      std::fill(ws.acc.begin() + static_cast<size_t>(y0) * W,
                ws.acc.begin() + static_cast<size_t>(y1) * W, Rgba{0, 0, 0, 0});
    });
    ensure_size(ws.tile_class, static_cast<size_t>(tw) * th);
    max_level = pyramid_max_level(W, H);
    timings.setup_ms += ms_since(t0);

    acc = ws.acc.data();
    // Slab composite: the hat's halves of layer i are blurred separately; the far half joins the
    // pending near half of layer i+1 (the same slab [c_i, c_{i+1}]) by addition, and the slab goes
    // "over" what lies behind. `pending` holds that near half, inside `pending_box`.
    if (slabs) {
      if (ws.pending.size() < N || !ws.pending_zero) {
        ensure_size(ws.pending, N);
        std::fill(ws.pending.begin(), ws.pending.end(), Rgba{0, 0, 0, 0});
      }
      ws.pending_zero = false;  // until the last flush
      pending = ws.pending.data();
    }
    fill_base_level = &ws.pull_push[std::min(fill_level, pp_levels - 1)];
    matte.c0 = static_cast<float>(plan.origin);
    matte.inv_step = plan.step > 0 ? static_cast<float>(1.0 / plan.step) : 0.0f;
    matte.n = n;
  }

  // The pinhole colour and CoC as one RGBA stream.
  void pack_pixels() {
    ensure_size(ws.packed, N);
    px = ws.packed.data();
    parallel_rows(H, [&](int y0, int y1) {
      for (size_t p = static_cast<size_t>(y0) * W; p < static_cast<size_t>(y1) * W; ++p)
        px[p] = Rgba{color[3 * p], color[3 * p + 1], color[3 * p + 2], ws.coc[p]};
    });
  }

  // Revealed fragments, packed by pixel then layer.
  void pack_revealed() {
    ws.revealed_count = 0;
    if (!occlusion) return;
    CocMap coc_of(in.imaging, options.max_coc_radius);
    ensure_size(ws.revealed_bits, N);
    ensure_size(ws.revealed_first, N);
    std::vector<const RevealedLayer*> by_layer(n, nullptr);
    for (const RevealedLayer& r : in.revealed) {
      int j = -1;
      for (int k = 0; k < n; ++k) {
        double z = plan.layers[k].depth;
        if (z == r.near_depth || std::abs(z - r.near_depth) <= 1e-9 * std::abs(z)) j = k;
      }
      if (j < 0)
        throw Error("preview: a revealed layer's near depth (" + std::to_string(r.near_depth) +
                    " m) matches no layer of the plan; plan the layers with the same options");
      check_revealed_layer_size(r, W, H);
      if (j == 0) continue;  // mask_0 is empty by definition
      by_layer[j] = &r;
    }
    // One pass over the rows, all masks per row (the row of bits stays in cache), counting the
    // fragments per row; then offsets: prefix over rows, then per pixel with the fragments.
    std::vector<int> row_start(H + 1, 0);
    parallel_rows(H, [&](int y0, int y1) {
      for (int y = y0; y < y1; ++y) {
        std::uint64_t* bits = ws.revealed_bits.data() + static_cast<size_t>(y) * W;
        std::fill(bits, bits + W, 0);
        int c = 0;  // the row's fragments
        for (int j = 1; j < n; ++j) {
          if (!by_layer[j]) continue;
          const float* m = by_layer[j]->mask.data().data() + static_cast<size_t>(y) * W;
          // Most rows of a mask are empty: a vectorised count finds them before any bit is set.
          int count = 0;
          for (int x = 0; x < W; ++x) count += m[x] > 0.5f;
          if (!count) continue;
          c += count;
          const std::uint64_t bit = std::uint64_t{1} << j;
          for (int x = 0; x < W; ++x) bits[x] |= m[x] > 0.5f ? bit : 0;
        }
        row_start[y + 1] = c;
      }
    });
    for (int y = 0; y < H; ++y) row_start[y + 1] += row_start[y];
    ws.revealed_count = static_cast<size_t>(row_start[H]);
    ensure_size(ws.revealed, ws.revealed_count);
    parallel_rows(H, [&](int y0, int y1) {
      for (int y = y0; y < y1; ++y) {
        int k = row_start[y];
        for (size_t p = static_cast<size_t>(y) * W; p < static_cast<size_t>(y + 1) * W; ++p) {
          std::uint64_t b = ws.revealed_bits[p];
          ws.revealed_first[p] = b ? k : -1;
          for (; b; b &= b - 1, ++k) {
            const RevealedLayer& r = *by_layer[ctz64(b)];
            const float* c = r.color.data().data() + 3 * p;
            ws.revealed[k] = Rgba{c[0], c[1], c[2], coc_of(r.depth.data()[p])};
          }
        }
      }
    });
  }

  // 2x2 block, 4x4 cell and 16x16 tile summaries, and the pull-push pyramid prepared.
  void summarise() {
    bw = (W + 1) / 2;
    bh = (H + 1) / 2;
    ensure_size(ws.blocks, static_cast<size_t>(bw) * bh);
    parallel_rows(bh, [&](int y0, int y1) {
      for (int by = y0; by < y1; ++by)
        for (int bx = 0; bx < bw; ++bx) {
          Block blk;
          const size_t p = static_cast<size_t>(2 * by) * W + 2 * bx;
          if (2 * bx + 2 <= W && 2 * by + 2 <= H) {  // a whole block
            const Rgba &a = px[p], &b = px[p + 1], &c = px[p + W], &d = px[p + W + 1];
            blk.mean = (((a + b) + c) + d) * 0.25f;  // the order of the general case below
            blk.cmin = std::min(std::min(a.a, b.a), std::min(c.a, d.a));
            blk.cmax = std::max(std::max(a.a, b.a), std::max(c.a, d.a));
            blk.bits = occlusion ? (ws.revealed_bits[p] | ws.revealed_bits[p + 1]) |
                                       (ws.revealed_bits[p + W] | ws.revealed_bits[p + W + 1])
                                 : 0;
          } else {  // on the last row or column
            blk = kNoPixels;
            int count = 0;
            for (int y = 2 * by; y < std::min(2 * by + 2, H); ++y)
              for (int x = 2 * bx; x < std::min(2 * bx + 2, W); ++x) {
                const size_t q = static_cast<size_t>(y) * W + x;
                blk.mean = blk.mean + px[q];
                blk.cmin = std::min(blk.cmin, px[q].a);
                blk.cmax = std::max(blk.cmax, px[q].a);
                if (occlusion) blk.bits |= ws.revealed_bits[q];
                ++count;
              }
            blk.mean = blk.mean * (1.0f / count);
          }
          ws.blocks[static_cast<size_t>(by) * bw + bx] = blk;
        }
    });
    // The fill's base: pull-push level 2 (4x4 pixels), or level 1 on images too small for it.
    // Cells of 4x4 rather than 2x2 blocks: a quarter of the cells to sort into kept, culled and
    // mixed per layer (the fill was the pass that read the most memory per layer), and no more
    // error (slightly less for Kraus & Strengert on the shipped scenes: docs/preview.md). The slab
    // composite keeps level 1: its backing along a contour needs the finer fill (silhouette_test).
    pp_levels = prepare_pull_push(ws.pull_push, W, H, 4);
    fill_level = pp_levels >= 3 && !slabs ? 2 : 1;
    // 4x4 cells (2x2 blocks): the summary of the fill's base on level 2.
    const int cw4 = (bw + 1) / 2, ch4 = fill_level == 2 ? (bh + 1) / 2 : 0;
    ensure_size(ws.cells, static_cast<size_t>(cw4) * ch4);
    parallel_rows(ch4, [&](int y0, int y1) {
      for (int cy = y0; cy < y1; ++cy)
        for (int cx = 0; cx < cw4; ++cx) {
          Block cell = kNoPixels;
          int count = 0;
          for (int by = 2 * cy; by < std::min(2 * cy + 2, bh); ++by)
            for (int bx = 2 * cx; bx < std::min(2 * cx + 2, bw); ++bx) {
              const Block& blk = ws.blocks[static_cast<size_t>(by) * bw + bx];
              const int n = block_pixels(bx, by);
              cell.mean = cell.mean + blk.mean * static_cast<float>(n);
              cell.cmin = std::min(cell.cmin, blk.cmin);
              cell.cmax = std::max(cell.cmax, blk.cmax);
              cell.bits |= blk.bits;
              count += n;
            }
          cell.mean = cell.mean * (1.0f / count);
          ws.cells[static_cast<size_t>(cy) * cw4 + cx] = cell;
        }
    });
    tw = (W + kTile - 1) / kTile;
    th = (H + kTile - 1) / kTile;
    ensure_size(ws.tiles, static_cast<size_t>(tw) * th);
    parallel_rows(
        th,
        [&](int ty0, int ty1) {
          for (int ty = ty0; ty < ty1; ++ty)
            for (int tx = 0; tx < tw; ++tx) {
              Tile t{kInf, -kInf, 0};
              // From the 2x2 blocks: min, max and union are the same over either.
              for (int by = ty * kTile / 2; by < std::min((ty + 1) * kTile / 2, bh); ++by)
                for (int bx = tx * kTile / 2; bx < std::min((tx + 1) * kTile / 2, bw); ++bx) {
                  const Block& blk = ws.blocks[static_cast<size_t>(by) * bw + bx];
                  t.cmin = std::min(t.cmin, blk.cmin);
                  t.cmax = std::max(t.cmax, blk.cmax);
                  t.bits |= blk.bits;
                }
              ws.tiles[static_cast<size_t>(ty) * tw + tx] = t;
            }
        },
        1);
  }

  int block_pixels(int bx, int by) const {  // 4, or fewer on the last row or column
    return (std::min(2 * bx + 2, W) - 2 * bx) * (std::min(2 * by + 2, H) - 2 * by);
  }

  // The revealed fragment that fills pixel p in a layer that may use the A_j in `layers`: the
  // nearest one, or none.
  const Rgba* fragment(size_t p, std::uint64_t layers) const {
    const std::uint64_t b = layers ? ws.revealed_bits[p] & layers : 0;
    if (!b) return nullptr;
    return &ws.revealed[ws.fragment_of_layer(p, ctz64(b))];
  }

  // Of a block, cell or tile summary: every pixel kept; every pixel culled with no revealed
  // fragment to show (what pull-push must fill).
  template <class Summary>
  bool all_kept(const Summary& s) const {
    return s.cmin >= cull;
  }
  template <class Summary>
  bool all_unknown(const Summary& s) const {
    return s.cmax < cull && !(s.bits & usable);
  }

  void wrote(const Box& b) {  // a blur added into `pending` here
    if (slabs) grow(pending_box, b);
  }

  // ------------------------------------------------------- culling + disocclusion (pull)
  void disocclude(int i) {
    // Culling: c < c_{i-2} on the trapezoid (its rising ramp keeps a copy of nearer content),
    // c < c_{i-1} on the hat. Revealed fill: the nearest A_j with j >= max(i-1, 1).
    const int cull_rank = slabs ? 1 : 2;
    cull = i >= cull_rank ? static_cast<float>(plan.anchor(i - cull_rank)) : -kInf;
    const int lowest = std::max(i - 1, 1);
    usable = occlusion && lowest < 64 ? ~((std::uint64_t{1} << lowest) - 1) : 0;
    // With revealed layers, a pixel on layer i's rising ramp (c_{i-2} <= c < c_{i-1}) whose
    // hidden surface is known shows that surface in layer i, not the ramp copy of its pinhole
    // surface: inside the foreground the nearer layers cover layer i anyway (the foreground's
    // plateau copy is opaque), and where their blurred silhouette lets layer i through, a lens
    // ray passes the foreground and sees what lies behind it.
    reveal_cut = usable && i >= 1 && !slabs ? static_cast<float>(plan.anchor(i - 1)) : -kInf;

    auto t1 = clock::now();
    any_unknown = false;
    if (i >= cull_rank && cull > static_cast<float>(plan.coc_min) && pp_levels > fill_level) {
      PullPushLevel& lf = ws.pull_push[fill_level];
      const int span = 1 << (fill_level - 1);  // 2x2 blocks per fill cell, each way
      const std::vector<Block>& summary = fill_level == 2 ? ws.cells : ws.blocks;
      std::atomic<long> unknown{0};
      parallel_rows(
          lf.height,
          [&](int y0, int y1) {
            long local_unknown = 0;
            for (int cy = y0; cy < y1; ++cy)
              for (int cx = 0; cx < lf.width; ++cx) {
                float* q = lf.data.data() + (static_cast<size_t>(cy) * lf.width + cx) * 5;
                const Block& cell = summary[static_cast<size_t>(cy) * lf.width + cx];
                if (all_kept(cell)) {
                  q[0] = cell.mean.r;
                  q[1] = cell.mean.g;
                  q[2] = cell.mean.b;
                  q[3] = cell.mean.a;
                  q[4] = 1;
                  continue;
                }
                if (all_unknown(cell)) {
                  q[4] = 0;
                  ++local_unknown;
                  continue;
                }
                Rgba sum{0, 0, 0, 0};
                int known = 0;
                for (int by = cy * span; by < std::min((cy + 1) * span, bh); ++by)
                  for (int bx = cx * span; bx < std::min((cx + 1) * span, bw); ++bx) {
                    const Block& blk = ws.blocks[static_cast<size_t>(by) * bw + bx];
                    const int count = block_pixels(bx, by);
                    if (all_kept(blk)) {
                      sum = sum + blk.mean * static_cast<float>(count);
                      known += count;
                      continue;
                    }
                    if (all_unknown(blk)) {
                      local_unknown += count;
                      continue;
                    }
                    for (int y = 2 * by; y < std::min(2 * by + 2, H); ++y)
                      for (int x = 2 * bx; x < std::min(2 * bx + 2, W); ++x) {
                        size_t p = static_cast<size_t>(y) * W + x;
                        const Rgba* v = &px[p];
                        if (px[p].a < cull) {
                          v = fragment(p, usable);
                          if (!v) {
                            ++local_unknown;
                            continue;
                          }
                        }
                        sum = sum + *v;
                        ++known;
                      }
                  }
                float inv = known ? 1.0f / known : 0.0f;
                q[0] = sum.r * inv;
                q[1] = sum.g * inv;
                q[2] = sum.b * inv;
                q[3] = sum.a * inv;
                q[4] = known ? 1.0f : 0.0f;
              }
            unknown += local_unknown;
          },
          8);
      any_unknown = unknown.load() > 0;
      if (any_unknown)
        pull_push_levels(ws.pull_push, pp_levels, 4, slabs ? PullFilter::Tent : PullFilter::Box,
                         fill_level);
    }
    timings.fill_ms += ms_since(t1);
  }

  // ------------------------------------------------------- matting, blur and blend
  // One matte part of layer i: matting, blur, and into the composite or the pending slab.
  void matte_and_blur(int i, MattePart part) {
    const Box box = classify_tiles(i, part);
    if (box.empty()) return;
    ++timings.layers_blurred;

    auto t3 = clock::now();
    ensure_size(ws.runs, 32);  // a level's runs per pyramid level (views[32] below)
    LevelBlend lb =
        level_blend_for_radius(plan.layers[i].blur_radius, max_level, options.blend_pyramid_levels);
    const int top = lb.t > 0 ? lb.level + 1 : lb.level;
    // Into the composite ("over"), or added to the pending slab.
    Rgba* const target = slabs ? pending : acc;
    const Over over{slabs};
    const double radius = plan.layers[i].blur_radius;
    if (top > 0 && radius < std::min(options.direct_blur_radius, double{kMaxDirectBlurRadius}))
      blur_direct(radius, box, target, over);
    else if (top == 0)
      blend_sharp(box, target, over);
    else
      blur_pyramid(lb, top, box, target, over);
    timings.blur_blend_ms += ms_since(t3);
  }

  // Tiles are classified once per matte part (band_runs: per tile row, its runs of tiles whose
  // matte can be non-zero); matte_row then produces any row segment of the premultiplied layer on
  // demand (the pyramid's first reduce consumes it, so the full-resolution layer is never stored).
  // Returns the box of the tiles whose matte can be non-zero.
  Box classify_tiles(int i, MattePart part) {
    const PullPushLevel& fill_base = *fill_base_level;
    matte.i = i;
    matte.part = part;
    auto t2 = clock::now();
    // The part's matte is zero at and behind `behind` and at and before `lo`.
    float behind, lo;
    switch (matte.part) {
      case MattePart::Trapezoid:  // zero from c_{i+1} on (not the back layer), up to c_{i-2}
        behind = i + 1 < n ? static_cast<float>(plan.anchor(i + 1)) : kInf;
        lo = i >= 2 ? cull : -kInf;
        break;
      case MattePart::NearHalf:  // non-zero on (c_{i-1}, c_i]
        behind = n > 1 ? std::nextafter(static_cast<float>(plan.anchor(i)), kInf) : kInf;
        lo = i >= 1 ? cull : -kInf;
        break;
      case MattePart::FarHalf:  // non-zero on (c_i, c_{i+1})
        behind = i + 1 < n ? static_cast<float>(plan.anchor(i + 1)) : kInf;
        lo = n > 1 ? static_cast<float>(plan.anchor(i)) : kInf;
        break;
    }
    band_runs.assign(th, Runs{});
    parallel_rows(
        th,
        [&](int ty0, int ty1) {
          for (int ty = ty0; ty < ty1; ++ty) {
            for (int tx = 0; tx < tw; ++tx) {
              const size_t ti = static_cast<size_t>(ty) * tw + tx;
              const Tile& tile = ws.tiles[ti];
              TileClass cls;
              bool nonzero;
              if (tile.cmin >= behind) {
                cls = TileClass::Skip;
                nonzero = false;
              } else if (all_kept(tile) && !(tile.cmin < reveal_cut && (tile.bits & usable))) {
                cls = TileClass::Kept;
                nonzero = tile.cmax > lo;  // some c in (lo, behind)
              } else if (all_unknown(tile)) {
                cls = any_unknown ? TileClass::Culled : TileClass::Skip;
                nonzero = any_unknown;
                if (any_unknown) {  // the filled CoC over the tile's footprint on the fill's base
                  float fmin = std::numeric_limits<float>::infinity(), fmax = -fmin;
                  const int f = 1 << fill_level;
                  const int cx0 = std::max(tx * kTile / f - 1, 0),
                            cx1 = std::min((tx + 1) * kTile / f + 1, fill_base.width);
                  const int cy0 = std::max(ty * kTile / f - 1, 0),
                            cy1 = std::min((ty + 1) * kTile / f + 1, fill_base.height);
                  for (int cy = cy0; cy < cy1; ++cy)
                    for (int cx = cx0; cx < cx1; ++cx) {
                      float c =
                          fill_base.data[(static_cast<size_t>(cy) * fill_base.width + cx) * 5 + 3];
                      fmin = std::min(fmin, c);
                      fmax = std::max(fmax, c);
                    }
                  nonzero = fmin < behind && (fmax > lo || part == MattePart::FarHalf);
                  if (!nonzero) cls = TileClass::Skip;
                }
              } else {
                cls = TileClass::Mixed;
                nonzero = true;
              }
              ws.tile_class[ti] = static_cast<unsigned char>(cls);
              if (nonzero) band_runs[ty].append({tx * kTile, std::min((tx + 1) * kTile, W)});
            }
          }
        },
        1);
    Box box{W, H, 0, 0};
    for (int ty = 0; ty < th; ++ty) {
      const Span b = band_runs[ty].bounds();
      if (!b.empty()) grow(box, {b.x0, ty * kTile, b.x1, std::min((ty + 1) * kTile, H)});
    }
    timings.matting_ms += ms_since(t2);
    return box;
  }

  // Per row of `crop`, its runs of tiles whose matte can be non-zero (relative to the crop); the
  // whole row without crop_layers.
  void matte_runs(const Box& crop, std::vector<Runs>& runs) const {
    if (!options.crop_layers)
      return runs.assign(crop.y1 - crop.y0, Runs::whole(crop.x1 - crop.x0));
    runs.assign(crop.y1 - crop.y0, Runs{});
    for (int y = crop.y0; y < crop.y1; ++y)
      for (const Span& r : band_runs[y / kTile]) {
        const Span s{std::max(r.x0, crop.x0) - crop.x0, std::min(r.x1, crop.x1) - crop.x0};
        if (!s.empty()) runs[y - crop.y0].append(s);
      }
  }

  // Premultiplied layer pixels [xa, xb) of row y into out.
  void matte_row(int y, int xa, int xb, Rgba* out) const {
    const PullPushLevel& fill_base = *fill_base_level;
    const Matte m = matte;  // a local copy: stores through `out` cannot alias it
    const int ty = y / kTile;
    Rgba* culled_tmp = nullptr;  // scratch of pull_push_sample_row, fetched once per row
    const Rgba* src = px + static_cast<size_t>(y) * W;
    for (int x = xa; x < xb;) {
      const int tx = x / kTile, xe = std::min(xb, (tx + 1) * kTile);
      const TileClass cls =
          static_cast<TileClass>(ws.tile_class[static_cast<size_t>(ty) * tw + tx]);
      Rgba* o = out - xa;
      switch (cls) {
        case TileClass::Skip:
          std::fill(o + x, o + xe, Rgba{0, 0, 0, 0});
          break;
        case TileClass::Kept:
          if (m.part == MattePart::Trapezoid)
            m.premultiply_trapezoid(src + x, o + x, xe - x);
          else
            for (int k = x; k < xe; ++k) o[k] = premultiply(src[k], m.weight(src[k].a));
          break;
        case TileClass::Culled: {
          if (!culled_tmp) culled_tmp = ws.scratch.get(6, kTile / 2 + 3);
          pull_push_sample_row(fill_base, y, x, xe, o + x, culled_tmp, fill_level);
          if (m.part == MattePart::Trapezoid)  // fill_weight is the trapezoid there
            m.premultiply_trapezoid(o + x, o + x, xe - x);
          else
            for (int k = x; k < xe; ++k) o[k] = premultiply(o[k], m.fill_weight(o[k].a));
          break;
        }
        case TileClass::Mixed: {
          Rgba filled[kTile];  // the fill along the tile's row, sampled once if needed
          bool sampled = false;
          for (int k = x; k < xe; ++k) {
            Rgba v = src[k];
            float alpha;
            const size_t p = static_cast<size_t>(y) * W + k;
            const Rgba* r = v.a < cull || v.a < reveal_cut ? fragment(p, usable) : nullptr;
            if (v.a >= cull && !(v.a < reveal_cut && r)) {
              alpha = m.weight(v.a);
            } else {
              if (r) {
                v = *r;
                alpha = m.revealed_weight(v.a);
              } else if (any_unknown) {
                if (!sampled) {
                  if (!culled_tmp) culled_tmp = ws.scratch.get(6, kTile / 2 + 3);
                  pull_push_sample_row(fill_base, y, x, xe, filled, culled_tmp, fill_level);
                  sampled = true;
                }
                v = filled[k - x];
                alpha = m.fill_weight(v.a);
              } else {
                alpha = 0;
              }
            }
            o[k] = alpha > 0 ? premultiply(v, alpha) : Rgba{0, 0, 0, 0};
          }
          break;
        }
      }
      x = xe;
    }
  }

  void blur_direct(double radius, const Box& box, Rgba* target, Over over) {
    // Small radius: the separable disk-profile kernel (pyramid.h), horizontal pass into
    // ws.direct, vertical pass fused with the "over". The crop grows the box by the kernel's
    // reach; beyond the box the matte is zero, so cropping changes nothing.
    const std::vector<float> taps = disk_profile_taps(radius);
    const int R = static_cast<int>(taps.size() / 2);
    const Box crop = options.crop_layers ? Box{std::max(box.x0 - R, 0), std::max(box.y0 - R, 0),
                                               std::min(box.x1 + R, W), std::min(box.y1 + R, H)}
                                         : Box{0, 0, W, H};
    wrote(crop);
    const int cw = crop.x1 - crop.x0, ch = crop.y1 - crop.y0;
    ensure_size(ws.direct, static_cast<size_t>(cw) * ch);
    Rgba* hbuf = ws.direct.data();
    std::vector<Runs>& mruns = ws.runs[0];  // of the matte, then of the horizontal pass
    matte_runs(crop, mruns);
    parallel_rows(ch, [&](int r0, int r1) {
      Rgba* row = ws.scratch.get(2, cw + 2 * R) + R;
      for (int y = r0; y < r1; ++y) {
        Rgba* h = hbuf + static_cast<size_t>(y) * cw;
        const Runs& m = mruns[y];
        Runs hr;  // the pixels the matte's runs reach
        for (const Span& s : m) hr.append({std::max(s.x0 - R, 0), std::min(s.x1 + R, cw)});
        hr.zero_outside(h, 0, cw);
        if (m.empty()) continue;
        // The matte, with zeros as far as the taps of those pixels read.
        const Span b = hr.bounds();
        m.zero_outside(row, std::max(b.x0 - R, 0), std::min(b.x1 + R, cw));
        for (const Span& s : m)
          matte_row(crop.y0 + y, crop.x0 + s.x0, crop.x0 + s.x1, row + s.x0);
        for (int k = 1; k <= R; ++k) {  // clamp to edge
          row[-k] = row[0];
          row[cw - 1 + k] = row[cw - 1];
        }
        with_radius(R, [&](auto r) {
          const int n = decltype(r)::value > 0 ? decltype(r)::value : R;
          for (const Span& s : hr)
            for (int x = s.x0; x < s.x1; ++x) {  // symmetric taps: +-k pairs share a product
              Float4 sum = as_vec(row[x]) * taps[n];
              for (int k = 1; k <= n; ++k)
                sum += (as_vec(row[x - k]) + as_vec(row[x + k])) * taps[n + k];
              h[x] = as_rgba(sum);
            }
        });
        mruns[y] = hr;
      }
    });
    parallel_rows(ch, [&](int r0, int r1) {
      for (int y = r0; y < r1; ++y) {
        Rgba* d = target + static_cast<size_t>(crop.y0 + y) * W + crop.x0;
        const Rgba* rows[2 * kMaxDirectBlurRadius + 1];
        Runs runs;  // where any of the rows read is non-zero
        for (int k = 0; k <= 2 * R; ++k) {
          const int yk = std::clamp(y - R + k, 0, ch - 1);
          rows[k] = hbuf + static_cast<size_t>(yk) * cw;
          runs = unite(runs, mruns[yk]);
        }
        with_radius(R, [&](auto r) {
          const int n = decltype(r)::value > 0 ? decltype(r)::value : R;
          for (const Span& s : runs)
            for (int x = s.x0; x < s.x1; ++x) {
              Float4 sum = as_vec(rows[n][x]) * taps[n];
              for (int k = 1; k <= n; ++k)
                sum += (as_vec(rows[n - k][x]) + as_vec(rows[n + k][x])) * taps[n + k];
              over(d[x], as_rgba(sum));
            }
        });
      }
    });
  }

  // A sharp layer: the matte straight into the composite.
  void blend_sharp(const Box& box, Rgba* target, Over over) {
    wrote(box);
    std::vector<Runs>& mruns = ws.runs[0];
    matte_runs(box, mruns);
    parallel_rows(box.y1 - box.y0, [&](int r0, int r1) {
      Rgba* tmp = ws.scratch.get(2, box.x1 - box.x0);
      for (int y = r0; y < r1; ++y)
        for (const Span& s : mruns[y]) {
          matte_row(box.y0 + y, box.x0 + s.x0, box.x0 + s.x1, tmp + s.x0);
          Rgba* d = target + static_cast<size_t>(box.y0 + y) * W + box.x0;
          for (int x = s.x0; x < s.x1; ++x) over(d[x], tmp[x]);
        }
    });
  }

  // The pyramid blur: reduce to level `top`, expand back, blending levels as `lb` says.
  void blur_pyramid(const LevelBlend& lb, int top, const Box& box, Rgba* target, Over over) {
    const Box crop = options.crop_layers ? crop_for(box, top, W, H) : Box{0, 0, W, H};
    wrote(crop);
    const int cw0 = crop.x1 - crop.x0, ch0 = crop.y1 - crop.y0;
    if (ws.pyramid.size() < static_cast<size_t>(top + 1)) ws.pyramid.resize(top + 1);
    RgbaView views[32];
    views[0] = {nullptr, cw0, ch0, 0};  // level 0 is produced row by row by matte_row
    // The rows' runs that can be non-zero, per level: every level is zero outside them (the
    // reduces and expands compute only there, and zero the rest of the rows they write).
    std::vector<std::vector<Runs>>& runs = ws.runs;
    matte_runs(crop, runs[0]);
    for (int k = 1; k <= top; ++k) {
      int w = (views[k - 1].width + 1) / 2, h = (views[k - 1].height + 1) / 2;
      ensure_size(ws.pyramid[k], static_cast<size_t>(w) * h);
      views[k] = {ws.pyramid[k].data(), w, h, w};
      reduce_runs(runs[k - 1].data(), views[k - 1].height, w, h, runs[k]);
      if (k == 1)
        reduce_box4_rows(cw0, ch0, views[1], ws.scratch, runs[0].data(), runs[1].data(),
                         [&](int y, int x0, int x1, Rgba* out) {
                           matte_row(crop.y0 + y, crop.x0 + x0, crop.x0 + x1, out + x0);
                         });
      else
        reduce_box4(views[k - 1], views[k], ws.scratch, runs[k].data());
    }
    // The runs of an expand from level k (whose runs are runs[k]) to level k - 1.
    std::vector<Runs>& expanded = ws.expanded_runs;
    auto expand_from = [&](int k) {
      expand_runs(runs[k].data(), views[k].height, k == 1 ? cw0 : views[k - 1].width,
                  k == 1 ? ch0 : views[k - 1].height, expanded);
      return expanded.data();
    };
    Rgba* acc0 = target + static_cast<size_t>(crop.y0) * W + crop.x0;
    const float t = lb.t, s = 1.0f - lb.t;
    // Outside an expand's runs both the expand and the level it joins (whose runs it covers) are
    // zero, and "over" zero leaves the composite as it is.
    if (lb.t > 0 && lb.level == 0) {
      // Blend level 0 (the sharp layer) with level 1 and composite.
      expand_bspline2(
          views[1], cw0, ch0, ws.scratch,
          [&](int y, const Rgba* e, const Runs& er) {
            Rgba* l = ws.scratch.get(2, cw0);
            Rgba* d = acc0 + static_cast<size_t>(y) * W;
            for (const Span& sp : er) {
              matte_row(crop.y0 + y, crop.x0 + sp.x0, crop.x0 + sp.x1, l + sp.x0);
              for (int x = sp.x0; x < sp.x1; ++x) over(d[x], l[x] * s + e[x] * t);
            }
          },
          expand_from(1));
    } else {
      if (lb.t > 0) {  // mix at level l: (1 - t) reduce_l + t expand(reduce_{l+1})
        const RgbaView& dst = views[lb.level];
        expand_bspline2(
            views[lb.level + 1], dst.width, dst.height, ws.scratch,
            [&](int y, const Rgba* e, const Runs& er) {
              Rgba* d = dst.row(y);
              for (const Span& sp : er)
                for (int x = sp.x0; x < sp.x1; ++x) d[x] = d[x] * s + e[x] * t;
            },
            expand_from(lb.level + 1));
        runs[lb.level].swap(expanded);
      }
      for (int k = lb.level; k >= 2; --k) {  // expand in place into the level below
        const RgbaView& dst = views[k - 1];
        expand_bspline2(
            views[k], dst.width, dst.height, ws.scratch,
            [&](int y, const Rgba* e, const Runs& er) {
              Rgba* d = dst.row(y);
              er.zero_outside(d, 0, dst.width);
              for (const Span& sp : er) std::copy(e + sp.x0, e + sp.x1, d + sp.x0);
            },
            expand_from(k));
        runs[k - 1].swap(expanded);
      }
      expand_bspline2(
          views[1], cw0, ch0, ws.scratch,
          [&](int y, const Rgba* e, const Runs& er) {
            Rgba* d = acc0 + static_cast<size_t>(y) * W;
            for (const Span& sp : er)
              for (int x = sp.x0; x < sp.x1; ++x) over(d[x], e[x]);
          },
          expand_from(1));
    }
  }

  // ------------------------------------------------------- flush
  void flush_pending() {  // acc = pending over acc; pending = 0
    if (pending_box.empty()) return;
    const Box b = pending_box;
    parallel_rows(b.y1 - b.y0, [&](int r0, int r1) {
      for (int y = b.y0 + r0; y < b.y0 + r1; ++y) {
        Rgba* d = acc + static_cast<size_t>(y) * W;
        Rgba* q = pending + static_cast<size_t>(y) * W;
        for (int x = b.x0; x < b.x1; ++x) {
          // A slab's parts and fills add up; where they cover more than the pixel (a fill's blur
          // reaching into the slab's own content), scale them to full coverage.
          const Rgba v = q[x].a > 1.0f ? q[x] * (1.0f / q[x].a) : q[x];
          d[x] = v + d[x] * (1.0f - v.a);
          q[x] = Rgba{0, 0, 0, 0};
        }
      }
    });
    pending_box = Box{W, H, 0, 0};
  }

  // ---------------------------------------------------------------- resolve
  void resolve() {
    auto t4 = clock::now();
    float* o = out.data().data();
    parallel_rows(H, [&](int y0, int y1) {
      for (size_t p = static_cast<size_t>(y0) * W; p < static_cast<size_t>(y1) * W; ++p) {
        const Rgba& a = acc[p];
        if (a.a > 1e-6f) {
          float inv = 1.0f / a.a;
          o[3 * p] = a.r * inv;
          o[3 * p + 1] = a.g * inv;
          o[3 * p + 2] = a.b * inv;
        } else {
          o[3 * p] = color[3 * p];
          o[3 * p + 1] = color[3 * p + 1];
          o[3 * p + 2] = color[3 * p + 2];
        }
      }
    });
    timings.resolve_ms += ms_since(t4);

    if (occlusion && options.edge_rays > 0) {
      auto t5 = clock::now();
      timings.traced_pixels = trace_edge_band(options, plan, W, H, ws, out);
      timings.trace_ms += ms_since(t5);
    }
  }

  const PreviewInputs& in;
  const PreviewOptions& options;
  const LayerPlan& plan;
  PreviewWorkspace::Impl& ws;
  image::Image& out;
  PreviewTimings& timings;

  const int W, H;
  const size_t N;
  const int n;               // layers
  const float* const color;  // the pinhole image
  const bool occlusion;      // with revealed layers
  const bool slabs;          // the slab composite (else "over")

  // setup
  Rgba* px = nullptr;  // ws.packed: {r, g, b, c}
  int bw = 0, bh = 0;  // 2x2 blocks
  int tw = 0, th = 0;  // 16x16 tiles
  int pp_levels = 0, fill_level = 1;
  int max_level = 0;
  Rgba* acc = nullptr;      // the composite
  Rgba* pending = nullptr;  // the slab composite's pending near half
  Box pending_box;
  const PullPushLevel* fill_base_level = nullptr;  // what the fill is sampled from

  // Culling and disocclusion state of the layer whose fill ws.pull_push holds: its cull threshold,
  // the revealed layers it may use, whether anything was filled.
  float cull = -kInf, reveal_cut = -kInf;
  std::uint64_t usable = 0;
  bool any_unknown = false;

  // The matte part under way.
  Matte matte;
  std::vector<Runs> band_runs;
};

}  // namespace

void check_revealed_layer_size(const RevealedLayer& r, int W, int H) {
  auto fits = [&](const image::Image& im, int channels) {
    return im.width() == W && im.height() == H && im.channels() == channels;
  };
  if (!fits(r.color, 3) || !fits(r.depth, 1) || !fits(r.mask, 1))
    throw Error(
        "preview: a revealed layer's colour (RGB), depth and mask must have the size of the "
        "pinhole image");
}

void layered_preview(const PreviewInputs& in, const PreviewOptions& options, const LayerPlan& plan,
                     bool occlusion, PreviewWorkspace::Impl& ws, image::Image& out,
                     PreviewTimings& timings) {
  LayeredComposite(in, options, plan, occlusion, ws, out, timings).run();
}

}  // namespace dofcache::preview::detail
