#pragma once
// Internal: the scratch memory of render_preview and the per-method pipelines it dispatches to.
#include <cstdint>
#include <vector>

#include "dofcache/preview/layers.h"
#include "dofcache/preview/preview.h"
#include "kernels.h"

namespace dofcache::preview {
namespace detail {
struct EdgeSeed {  // an edge pixel and its radius (0: none), with its reach at a block's centre
  float x, y, r, reach;
};
}  // namespace detail

struct PreviewWorkspace::Impl {
  std::vector<float> coc;  // signed CoC of every pinhole pixel (clamped)
  detail::ScratchRows scratch;

  // layered
  std::vector<detail::Rgba> packed;          // pinhole colour and CoC: {r, g, b, c}
  std::vector<std::uint64_t> revealed_bits;  // bit j: A_j is valid at this pixel
  std::vector<int> revealed_first;           // index of the pixel's first fragment, or -1
  std::vector<detail::Rgba> revealed;        // fragments {r, g, b, c}, by pixel then layer
  size_t revealed_count = 0;                 // fragments of this call (revealed may hold more)
  // Pixel p's fragments are revealed[revealed_first[p] + k], one per bit of revealed_bits[p]
  // (layer j), in layer order. The index of p's fragment of A_j, or -1.
  int fragment_of_layer(size_t p, int j) const {
    const std::uint64_t bits = revealed_bits[p];
    if (!((bits >> j) & 1)) return -1;
    return revealed_first[p] + detail::popcount64(bits & ((std::uint64_t{1} << j) - 1));
  }
  struct Block {        // 2x2 pixels
    detail::Rgba mean;  // of {r, g, b, c}
    float cmin, cmax;
    std::uint64_t bits;  // revealed layers present in the block
  };
  std::vector<Block> blocks;
  std::vector<Block> cells;  // 4x4 pixels (2x2 blocks)
  struct Tile {              // 16x16 pixels
    float cmin, cmax;
    std::uint64_t bits;  // revealed layers present in the tile
  };
  std::vector<Tile> tiles;
  std::vector<unsigned char> tile_class;  // per layer: how its pixels are matted
  std::vector<detail::PullPushLevel> pull_push;
  std::vector<detail::Rgba> acc;
  std::vector<detail::Rgba> pending;  // the slab composite's pending near half
  bool pending_zero = false;          // every flush zeroes it: set after a complete composite
  std::vector<std::vector<detail::Rgba>> pyramid;
  std::vector<detail::Rgba> direct;  // horizontal pass of the direct (small-radius) blur
  std::vector<std::vector<detail::Runs>> runs;  // per pyramid level, its rows' non-zero runs
  std::vector<detail::Runs> expanded_runs;      // those of the expand under way

  // occlusion fix: edge trace (edge_trace.cpp)
  std::vector<std::uint64_t> trace_bins;      // CoC bins occupied per pixel and per fragment
  std::vector<float> trace_reach;             // signed distance into the edge band
  std::vector<detail::EdgeSeed> trace_seeds;  // per 2x2 block: the edge disk reach is measured to

  // gather / scatter
  std::vector<float> radius, inv_area, plane_r, plane_g, plane_b;
  std::vector<float> tile_radius;
  std::vector<int> bin_start, bin_pixels;
  std::vector<double> diff;
  std::vector<float> shaped_acc;  // shaped scatter: colour and alpha per channel
};

namespace detail {

// Throws dofcache::Error (one line) unless the revealed layer's colour (RGB), depth and mask have
// the pinhole image's size, W x H: both pipelines that draw revealed layers check it.
void check_revealed_layer_size(const RevealedLayer& r, int W, int H);

// The layered pipeline (Kraus & Strengert; with the paper's occlusion fix if `occlusion`).
// ws.coc must hold the pinhole CoC. Writes RGB into `out` (already sized).
void layered_preview(const PreviewInputs& inputs, const PreviewOptions& options,
                     const LayerPlan& plan, bool occlusion, PreviewWorkspace::Impl& ws,
                     image::Image& out, PreviewTimings& timings);
// The occlusion fix's edge trace (edge_trace.cpp): replaces the layer composite in `out` near
// occluding edges by options.edge_rays lens rays traced through ws.packed and the revealed
// fragments (ws.revealed*, if any). Returns the number of pixels traced (the band's).
long trace_edge_band(const PreviewOptions& options, const LayerPlan& plan, int width, int height,
                     PreviewWorkspace::Impl& ws, image::Image& out);
void gather_preview(const image::Image& color, const PreviewOptions& options,
                    PreviewWorkspace::Impl& ws, image::Image& out);
void scatter_preview(const image::Image& color, const PreviewOptions& options,
                     PreviewWorkspace::Impl& ws, image::Image& out);
// The lens's own bokeh (preview.h): every pixel splats the aperture's shape where
// render::ThinLensCamera::bokeh puts it, per colour band, cut by the vignetting stop. ws.coc must
// hold the pinhole CoC (the depth order).
// The shaped scatter (scatter.cpp), with the inputs' revealed layers if `revealed` (the
// occlusion fix). Returns the revealed fragments it splatted.
std::size_t shaped_scatter_preview(const PreviewInputs& inputs, const PreviewOptions& options,
                                   bool revealed, PreviewWorkspace::Impl& ws, image::Image& out);

}  // namespace detail
}  // namespace dofcache::preview
