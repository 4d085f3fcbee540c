#pragma once
// Internal: the scratch memory of render_preview and the per-method pipelines it dispatches to.
#include <cstdint>
#include <vector>

#include "dofcache/preview/layers.h"
#include "dofcache/preview/preview.h"
#include "kernels.h"

namespace dofcache::preview {

struct PreviewWorkspace::Impl {
  std::vector<float> coc;  // signed CoC of every pinhole pixel (clamped)
  detail::ScratchRows scratch;

  // layered
  std::vector<detail::Rgba> packed;          // pinhole colour and CoC: {r, g, b, c}
  std::vector<std::uint64_t> revealed_bits;  // bit j: A_j is valid at this pixel
  std::vector<int> revealed_first;           // index of the pixel's first fragment, or -1
  std::vector<detail::Rgba> revealed;        // fragments {r, g, b, c}, by pixel then layer
  struct Block {                             // 2x2 pixels
    detail::Rgba mean;                       // of {r, g, b, c}
    float cmin, cmax;
    std::uint64_t bits;  // revealed layers present in the block
  };
  std::vector<Block> blocks;
  struct Tile {  // 16x16 pixels
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

  // gather / scatter
  std::vector<float> radius, inv_area, plane_r, plane_g, plane_b;
  std::vector<float> tile_radius;
  std::vector<int> bin_start, bin_pixels;
  std::vector<double> diff;
};

namespace detail {

// The layered pipeline (Kraus & Strengert; with the paper's occlusion fix if `occlusion`).
// ws.coc must hold the pinhole CoC. Writes RGB into `out` (already sized).
void layered_preview(const PreviewInputs& inputs, const PreviewOptions& options,
                     const LayerPlan& plan, bool occlusion, PreviewWorkspace::Impl& ws,
                     image::Image& out, PreviewTimings& timings);
void gather_preview(const image::Image& color, const PreviewOptions& options,
                    PreviewWorkspace::Impl& ws, image::Image& out);
void scatter_preview(const image::Image& color, const PreviewOptions& options,
                     PreviewWorkspace::Impl& ws, image::Image& out);

}  // namespace detail
}  // namespace dofcache::preview
