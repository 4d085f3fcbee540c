#include "dofcache/preview/preview_renderer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "dofcache/core/error.h"
#include "dofcache/preview/occlusion.h"

namespace dofcache::preview {
namespace {

using clock = std::chrono::steady_clock;

double ms_since(clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(clock::now() - t0).count();
}

// Ids are stored as floats: exact below 2^24.
constexpr std::size_t kMaxExactId = std::size_t{1} << 24;

// L_j: the ids seen with the near plane at z_j. Only pixels whose pinhole surface the plane clips
// are traced; every other pixel sees its pinhole surface, the nearest hit beyond the plane as well.
// (A relative margin traces the pixels within float rounding of the plane too.)
image::Image id_layer(const scene::Scene& scene, const scene::Accel& accel,
                      const scene::Camera& camera, const render::RenderSettings& base,
                      const image::Image& pinhole_depth, const image::Image& pinhole_ids,
                      double near_depth) {
  const int w = pinhole_depth.width(), h = pinhole_depth.height();
  if (!std::isfinite(near_depth)) return image::Image(w, h, 1, -1.0f);
  const float limit = static_cast<float>(near_depth * (1.0 + 1e-4));
  image::Image clipped(w, h, 1, 0.0f);
  bool any = false;
  for (size_t p = 0; p < pinhole_depth.pixel_count(); ++p)
    if (pinhole_depth.data()[p] < limit) clipped.data()[p] = 1.0f, any = true;
  image::Image ids = pinhole_ids;
  if (!any) return ids;
  render::RenderSettings s = base;
  s.visibility_only = true;
  s.near_depth = static_cast<float>(near_depth);
  s.mask = &clipped;
  s.progress = Progress::Display::Never;
  render::RenderOutput out = render::render(scene, accel, camera, s);
  for (size_t p = 0; p < ids.pixel_count(); ++p)
    if (clipped.data()[p] > 0.5f) ids.data()[p] = out.ids.data()[p];
  return ids;
}

std::uint64_t count_set(const image::Image& mask) {
  std::uint64_t n = 0;
  for (float v : mask.data()) n += v > 0.5f;
  return n;
}

}  // namespace

render::ShadingSettings quick_input_shading(const render::ShadingSettings& full, bool indirect) {
  render::ShadingSettings s = full;
  s.light_samples = std::min(full.light_samples, 1);
  s.gather_rays = indirect ? std::min(full.gather_rays, 2) : 0;
  s.bounces = indirect ? std::min(full.bounces, 1) : 0;
  s.specular_depth = std::min(full.specular_depth, 1);
  return s;
}

SceneInputs render_preview_inputs(const scene::Scene& scene, const scene::Accel& accel,
                                  const scene::Camera& camera,
                                  const render::RenderSettings& settings, PreviewMethod method,
                                  const PreviewOptions& options) {
  const auto start = clock::now();
  if (scene.mesh.triangles.size() >= kMaxExactId)
    throw Error("preview: the scene has too many triangles (" +
                std::to_string(scene.mesh.triangles.size()) +
                ") for exact float ids (at most 16777215)");
  render::RenderSettings base = settings;
  base.mode = render::Mode::Pinhole;
  base.near_depth = 0.0f;
  base.mask = nullptr;
  base.visibility_only = false;
  base.triangle_ids = true;
  base.validate();

  SceneInputs result;
  ScenePreviewTimings& t = result.timings;

  // 1. The pinhole render: colour, depth and ids.
  auto t0 = clock::now();
  render::RenderSettings pinhole = base;
  if (pinhole.progress_label == "render") pinhole.progress_label = "pinhole";
  render::RenderOutput out = render::render(scene, accel, camera, pinhole);
  t.pinhole_render_ms = ms_since(t0);
  t.pinhole_stats = out.stats;
  PreviewInputs& in = result.inputs;
  in.color = std::move(out.color);
  in.depth = std::move(out.depth);
  in.ids = std::move(out.ids);
  in.imaging = render::make_camera(camera, base).imaging();

  if (method == PreviewMethod::LayeredOcclusion) {
    // 2. The near-plane id layers and 3. the masks.
    const LayerPlan plan = plan_layers(in.depth, in.imaging, options);
    const int n = plan.size();
    result.coverage = revealed_coverage(plan, in.imaging);
    if (n >= 2) {
      t0 = clock::now();
      std::vector<image::Image> id_layers(n);
      id_layers[0] = in.ids;
      for (int j = 1; j < n; ++j)
        id_layers[j] = id_layer(scene, accel, camera, base, in.depth, in.ids, plan.layers[j].depth);
      t.id_render_ms = ms_since(t0);
      // No surface at all at or behind the last near plane: any farther plane reveals nothing
      // either, so the revealed layers cover every depth behind z_1.
      const std::vector<float>& last = id_layers[n - 1].data();
      if (std::all_of(last.begin(), last.end(), [](float id) { return id < 0.0f; }))
        result.coverage.far_depth = std::numeric_limits<double>::infinity();
      t0 = clock::now();
      std::vector<image::Image> masks =
          build_occlusion_masks(id_layers, in.depth, plan, in.imaging, options);
      t.mask_build_ms = ms_since(t0);

      // 4. The revealed layers, where the masks are set.
      t0 = clock::now();
      for (int j = 1; j < n; ++j) {
        std::uint64_t count = count_set(masks[j]);
        if (count == 0) continue;
        render::RenderSettings s = base;
        s.near_depth = static_cast<float>(plan.layers[j].depth);
        s.mask = &masks[j];
        s.progress_label = "layer " + std::to_string(j);
        render::RenderOutput a = render::render(scene, accel, camera, s);
        in.revealed.push_back(RevealedLayer{plan.layers[j].depth, std::move(a.color),
                                            std::move(a.depth), std::move(masks[j])});
        t.revealed_pixels += count;
      }
      t.revealed_layers = static_cast<int>(in.revealed.size());
      t.extra_render_ms = ms_since(t0);
    }
  }

  t.total_ms = ms_since(start);
  return result;
}

PreviewInputs upscale_inputs(const PreviewInputs& in, int width, int height) {
  if (!in.revealed.empty()) throw Error("preview: inputs with revealed layers cannot be upscaled");
  if (width <= 0 || height <= 0 || in.color.empty())
    throw Error("preview: cannot upscale inputs to " + std::to_string(width) + "x" +
                std::to_string(height));
  const int sw = in.color.width(), sh = in.color.height();
  auto nearest = [&](const image::Image& src) {
    image::Image dst(width, height, src.channels());
    for (int y = 0; y < height; ++y) {
      const int sy = std::min(sh - 1, static_cast<int>((y + 0.5) * sh / height));
      for (int x = 0; x < width; ++x) {
        const int sx = std::min(sw - 1, static_cast<int>((x + 0.5) * sw / width));
        std::copy_n(src.pixel(sx, sy), src.channels(), dst.pixel(x, y));
      }
    }
    return dst;
  };
  PreviewInputs out;
  out.color = nearest(in.color);
  out.depth = nearest(in.depth);
  out.ids = nearest(in.ids);
  out.imaging = in.imaging;
  out.imaging.y_resolution = height;
  return out;
}

ScenePreview render_scene_preview(const scene::Scene& scene, const scene::Accel& accel,
                                  const scene::Camera& camera,
                                  const render::RenderSettings& settings, PreviewMethod method,
                                  const PreviewOptions& options) {
  const auto start = clock::now();
  SceneInputs in = render_preview_inputs(scene, accel, camera, settings, method, options);
  ScenePreview result;
  result.timings = in.timings;
  ScenePreviewTimings& t = result.timings;
  // 5. The post-process.
  const auto t0 = clock::now();
  result.image = render_preview(in.inputs, method, options, &t.postprocess);
  t.postprocess_ms = ms_since(t0);
  t.layers = t.postprocess.layers;
  result.inputs = std::move(in.inputs);
  result.coverage = in.coverage;
  t.total_ms = ms_since(start);
  return result;
}

}  // namespace dofcache::preview
