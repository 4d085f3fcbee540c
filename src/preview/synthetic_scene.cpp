#include "dofcache/preview/synthetic_scene.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "dofcache/preview/occlusion.h"
#include "kernels.h"

namespace dofcache::preview {

void SyntheticScene::render(double near_depth, image::Image* color, image::Image* depth,
                            image::Image* ids) const {
  if (color) *color = image::Image(width, height, 3);
  if (depth) *depth = image::Image(width, height, 1);
  if (ids) *ids = image::Image(width, height, 1);
  detail::parallel_rows(height, [&](int y0, int y1) {
    for (int y = y0; y < y1; ++y)
      for (int x = 0; x < width; ++x) {
        const SyntheticRect* hit = nullptr;
        for (const SyntheticRect& r : rects)
          if (x >= r.x0 && x < r.x1 && y >= r.y0 && y < r.y1 && r.depth >= near_depth &&
              (!hit || r.depth < hit->depth))
            hit = &r;
        if (color) {
          const float* c = background;
          if (hit) {
            bool second = hit->checker > 0 &&
                          (((x - hit->x0) / hit->checker + (y - hit->y0) / hit->checker) & 1);
            c = second ? hit->color2 : hit->color;
          }
          std::copy(c, c + 3, color->pixel(x, y));
        }
        if (depth)
          depth->at(x, y, 0) =
              hit ? static_cast<float>(hit->depth) : std::numeric_limits<float>::infinity();
        if (ids) ids->at(x, y, 0) = hit ? hit->id : -1.0f;
      }
  });
}

PreviewInputs SyntheticScene::pinhole() const {
  PreviewInputs in;
  render(0.0, &in.color, &in.depth, &in.ids);
  in.imaging = imaging;
  return in;
}

std::vector<image::Image> SyntheticScene::id_layers(const LayerPlan& plan) const {
  std::vector<image::Image> layers(plan.size());
  for (int j = 0; j < plan.size(); ++j)
    render(j == 0 ? 0.0 : plan.layers[j].depth, nullptr, nullptr, &layers[j]);
  return layers;
}

PreviewInputs SyntheticScene::pinhole_with_revealed_layers(const PreviewOptions& options) const {
  PreviewInputs in = pinhole();
  const LayerPlan plan = plan_layers(in.depth, in.imaging, options);
  const std::vector<image::Image> masks =
      build_occlusion_masks(id_layers(plan), in.depth, plan, in.imaging, options);
  in.revealed = revealed_layers(plan, masks);
  return in;
}

std::vector<RevealedLayer> SyntheticScene::revealed_layers(
    const LayerPlan& plan, const std::vector<image::Image>& masks) const {
  std::vector<RevealedLayer> out;
  for (int j = 1; j < plan.size() && j < static_cast<int>(masks.size()); ++j) {
    const std::vector<float>& m = masks[j].data();
    if (std::none_of(m.begin(), m.end(), [](float v) { return v > 0.5f; })) continue;
    RevealedLayer r;
    r.near_depth = plan.layers[j].depth;
    render(r.near_depth, &r.color, &r.depth, nullptr);
    r.mask = masks[j];
    out.push_back(std::move(r));
  }
  return out;
}

lens::LensImaging demo_imaging(int y_resolution) {
  lens::LensImaging im;
  im.lens = lens::ThinLens{0.05, 1.4, 3.0};
  im.yfov = 0.6;
  im.y_resolution = y_resolution;
  return im;
}

SyntheticScene make_demo_scene(int width, int height) {
  SyntheticScene s;
  s.width = width;
  s.height = height;
  s.imaging = demo_imaging(height);
  auto X = [&](double f) { return static_cast<int>(std::lround(f * width)); };
  auto Y = [&](double f) { return static_cast<int>(std::lround(f * height)); };
  const int cell = std::max(2, height / 30);
  auto rect = [&](double x0, double y0, double x1, double y1, double depth, float id,
                  std::initializer_list<float> c1, std::initializer_list<float> c2, int checker) {
    SyntheticRect r;
    r.x0 = X(x0);
    r.y0 = Y(y0);
    r.x1 = X(x1);
    r.y1 = Y(y1);
    r.depth = depth;
    r.id = id;
    std::copy(c1.begin(), c1.end(), r.color);
    std::copy(c2.begin(), c2.end(), r.color2);
    r.checker = checker;
    s.rects.push_back(r);
  };
  // Backdrop behind the focal plane (the sky above it is at infinity).
  rect(0, 0.12, 1, 1, 12.0, 0, {0.8f, 0.75f, 0.6f}, {0.3f, 0.35f, 0.5f}, 2 * cell);
  // Floor: strips receding from 1 m (bottom) to 10 m.
  const int strips = 16;
  for (int k = 0; k < strips; ++k) {
    double y1 = 1.0 - 0.4 * k / strips, y0 = 1.0 - 0.4 * (k + 1) / strips;
    double depth = 1.0 + 9.0 * std::pow(static_cast<double>(k) / (strips - 1), 2.0);
    bool odd = k & 1;
    rect(0, y0, 1, y1, depth, 10.0f + k, {odd ? 0.2f : 0.6f, 0.5f, odd ? 0.6f : 0.2f},
         {0.1f, 0.1f, 0.1f}, 0);
  }
  // Objects: behind focus, in focus, in front, and one close to the lens.
  rect(0.62, 0.20, 0.90, 0.62, 6.0, 4, {0.2f, 0.7f, 0.3f}, {0.9f, 0.9f, 0.9f}, cell);
  rect(0.35, 0.25, 0.62, 0.72, 3.0, 1, {0.9f, 0.2f, 0.2f}, {1.0f, 1.0f, 0.9f}, cell);
  rect(0.10, 0.15, 0.30, 0.80, 1.6, 2, {0.2f, 0.3f, 0.9f}, {0.9f, 0.6f, 0.1f}, cell);
  rect(0.48, 0.55, 0.70, 0.95, 0.8, 3, {0.95f, 0.85f, 0.2f}, {0.15f, 0.1f, 0.1f}, cell);
  return s;
}

}  // namespace dofcache::preview
