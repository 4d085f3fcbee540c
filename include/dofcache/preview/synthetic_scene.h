#pragma once
// A synthetic scene of screen-aligned rectangles at constant depths, rendered exactly for any near
// clipping plane: pinhole colour/depth/ids, the near-plane id layers L_j and the revealed layers
// A_j. Stands in for the renderer in tests and benchmarks of the preview.
#include <limits>
#include <vector>

#include "dofcache/image/image.h"
#include "dofcache/lens/thin_lens.h"
#include "dofcache/preview/layers.h"
#include "dofcache/preview/preview.h"

namespace dofcache::preview {

struct SyntheticRect {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;  // pixel box [x0, x1) x [y0, y1)
  double depth = 1.0;                  // metres
  float id = 0;
  float color[3] = {1, 1, 1};
  float color2[3] = {0, 0, 0};  // second checker colour
  int checker = 0;              // checker cell size in pixels; 0 = flat color
};

// A rectangle of one colour.
inline SyntheticRect flat_rect(int x0, int y0, int x1, int y1, double depth, float id, float r,
                               float g, float b) {
  SyntheticRect q;
  q.x0 = x0, q.y0 = y0, q.x1 = x1, q.y1 = y1;
  q.depth = depth;
  q.id = id;
  q.color[0] = r, q.color[1] = g, q.color[2] = b;
  return q;
}

struct SyntheticScene {
  int width = 0, height = 0;
  std::vector<SyntheticRect> rects;          // where rectangles overlap, the nearest one is seen
  float background[3] = {0.5f, 0.6f, 0.8f};  // where no rectangle is hit: depth +inf, id -1
  lens::LensImaging imaging;

  // Colour, depth and ids seen with the near clipping plane at `near_depth` (rectangles nearer
  // than it are skipped). Any output pointer may be null.
  void render(double near_depth, image::Image* color, image::Image* depth, image::Image* ids) const;
  // The pinhole render (no near plane) as preview inputs, without revealed layers.
  PreviewInputs pinhole() const;
  // L_j for every layer of `plan` (L_0 is the pinhole id image).
  std::vector<image::Image> id_layers(const LayerPlan& plan) const;
  // A_j for every layer with a non-empty mask.
  std::vector<RevealedLayer> revealed_layers(const LayerPlan& plan,
                                             const std::vector<image::Image>& masks) const;
  // The pinhole inputs with the revealed layers the occlusion fix renders for `options`' plan.
  PreviewInputs pinhole_with_revealed_layers(const PreviewOptions& options) const;
};

// The synthetic scenes' camera: a 50 mm f/1.4 lens focused at 3 m, vertical field of view 0.6 rad,
// `y_resolution` pixels high.
lens::LensImaging demo_imaging(int y_resolution);

// The benchmark scene: a textured backdrop behind the focal plane, a floor of strips receding in
// depth, objects at and in front of the focal plane, seen through demo_imaging(height).
SyntheticScene make_demo_scene(int width, int height);

}  // namespace dofcache::preview
