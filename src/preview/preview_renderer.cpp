#include "dofcache/preview/preview_renderer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "dofcache/core/error.h"
#include "dofcache/core/stopwatch.h"
#include "dofcache/denoise/atrous.h"
#include "dofcache/preview/occlusion.h"

namespace dofcache::preview {
namespace {

using clock = std::chrono::steady_clock;


// Ids are stored as floats: exact below 2^24.
constexpr std::size_t kMaxExactId = std::size_t{1} << 24;

// The near-plane id layers L_0..L_{n-1}. L_j differs from the pinhole ids L_0 only where the
// plane z_j clips the pinhole surface (elsewhere that surface is the nearest hit beyond the plane
// too), and build_occlusion_masks reads it only within region_j and, for the rule (2) test of the
// layer before, region_{j-1} where L_{j-1} shows a surface L_0 does not (occlusion.h). Only those
// clipped pixels are traced: the rest keep L_0, which leaves the masks unchanged. (A relative
// margin treats pixels within float rounding of the plane as clipped too.)
class IdLayers {
 public:
  IdLayers(const scene::Scene& scene, const scene::Accel& accel, const scene::Camera& camera,
           const render::RenderSettings& base, const PreviewInputs& pinhole)
      : scene_(scene), accel_(accel), camera_(camera), base_(base), pinhole_(pinhole) {
    base_.visibility_only = true;
    base_.progress = Progress::Display::Never;
    // The farthest depth any surface has: no hit exists beyond a plane behind it.
    const render::ThinLensCamera cam = render::make_camera(camera, base);
    for (const glm::vec3& v : scene.mesh.positions) farthest_ = std::max(farthest_, static_cast<double>(cam.depth(v)));
  }

  // Whether the plane z has a surface at or behind it (+inf has none); no hit exists otherwise.
  bool any_surface_behind(double z) const { return z * (1.0 - 1e-4) <= farthest_; }

  // The layers up to the first plane behind every surface: the farther ones are empty (planes
  // lie front to back).
  int traced_layers(const LayerPlan& plan) const {
    int j = 1;
    while (j < plan.size() && any_surface_behind(plan.layers[j].depth)) ++j;
    return j;
  }

  // regions: lens_reach_regions for at least traced_layers(plan) layers.
  std::vector<image::Image> render(const LayerPlan& plan, const std::vector<image::Image>& regions,
                                   std::uint64_t* traced) {
    const int n = plan.size();
    std::vector<image::Image> layers(n);
    layers[0] = pinhole_.ids;
    for (int j = 1; j < n; ++j) {
      const double z = plan.layers[j].depth;
      if (!any_surface_behind(z)) {
        layers[j] = image::Image(pinhole_.ids.width(), pinhole_.ids.height(), 1, -1.0f);
        continue;
      }
      std::vector<std::uint32_t> needed, spared;
      select_pixels(z, regions[j], j >= 2 ? &regions[j - 1] : nullptr,
                    j >= 2 ? &layers[j - 1] : nullptr, &needed, &spared);
      layers[j] = pinhole_.ids;
      trace(z, needed, layers[j]);
      *traced += needed.size();
      // The coverage asks whether anything lies behind the last plane (preview_renderer.h):
      // where the needed pixels and L_0 see nothing there, the spared ones decide.
      if (j == n - 1 && !spared.empty() && nothing_seen(layers[j])) {
        trace(z, spared, layers[j]);
        *traced += spared.size();
      }
    }
    return layers;
  }

  static bool nothing_seen(const image::Image& ids) {
    return std::all_of(ids.data().begin(), ids.data().end(), [](float id) { return id < 0.0f; });
  }

 private:
  // The clipped pixels of plane z, split into those the masks read and the rest.
  void select_pixels(double z, const image::Image& region, const image::Image* region_before,
                     const image::Image* layer_before, std::vector<std::uint32_t>* needed,
                     std::vector<std::uint32_t>* spared) const {
    const float limit = static_cast<float>(z * (1.0 + 1e-4));
    const float* depth = pinhole_.depth.data().data();
    const float* id0 = pinhole_.ids.data().data();
    const float* in = region.data().data();
    const float* before = region_before ? region_before->data().data() : nullptr;
    const float* ids_before = layer_before ? layer_before->data().data() : nullptr;
    const auto count = static_cast<std::uint32_t>(pinhole_.depth.pixel_count());
    for (std::uint32_t p = 0; p < count; ++p) {
      if (!(depth[p] < limit)) continue;
      const bool read = in[p] > 0.5f || (before && before[p] > 0.5f && ids_before[p] >= 0.0f &&
                                         ids_before[p] != id0[p]);
      (read ? needed : spared)->push_back(p);
    }
  }

  void trace(double z, const std::vector<std::uint32_t>& pixels, image::Image& ids) const {
    if (pixels.empty()) return;
    render::RenderSettings s = base_;
    s.near_depth = static_cast<float>(z);
    const std::vector<render::PixelVisibility> seen =
        render::trace_pixel_centres(scene_, accel_, camera_, s, pixels);
    for (size_t i = 0; i < pixels.size(); ++i) ids.data()[pixels[i]] = seen[i].id;
  }

  const scene::Scene& scene_;
  const scene::Accel& accel_;
  const scene::Camera& camera_;
  render::RenderSettings base_;
  const PreviewInputs& pinhole_;
  double farthest_ = -std::numeric_limits<double>::infinity();
};

std::vector<std::uint32_t> set_pixels(const image::Image& mask) {
  std::vector<std::uint32_t> pixels;
  const auto count = static_cast<std::uint32_t>(mask.pixel_count());
  for (std::uint32_t p = 0; p < count; ++p)
    if (mask.data()[p] > 0.5f) pixels.push_back(p);
  return pixels;
}

// A_j: colour and depth with the near plane at `near_depth`, rendered at the masked pixels only
// (render::render_pixels: the values a masked render gives, black and +inf elsewhere).
RevealedLayer revealed_layer(const scene::Scene& scene, const scene::Accel& accel,
                             const scene::Camera& camera, const render::RenderSettings& base,
                             double near_depth, const std::vector<std::uint32_t>& pixels,
                             image::Image mask) {
  render::RenderSettings s = base;
  s.near_depth = static_cast<float>(near_depth);
  const std::vector<render::PixelRender> seen =
      render::render_pixels(scene, accel, camera, s, pixels);
  RevealedLayer a{near_depth, image::Image(mask.width(), mask.height(), 3, 0.0f),
                  image::Image(mask.width(), mask.height(), 1,
                               std::numeric_limits<float>::infinity()),
                  std::move(mask)};
  for (size_t i = 0; i < pixels.size(); ++i) {
    float* c = a.color.data().data() + static_cast<size_t>(pixels[i]) * 3;
    c[0] = seen[i].color.x, c[1] = seen[i].color.y, c[2] = seen[i].color.z;
    a.depth.data()[pixels[i]] = seen[i].depth;
  }
  return a;
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
  if (options.denoise) {
    // The pinhole colour denoised before the post-process blurs it, guided by the noise-free
    // albedo, normal, depth and object (the ids here are triangles': mapped to their objects).
    t0 = clock::now();
    image::Image objects(in.ids.width(), in.ids.height(), 1, -1.0f);
    for (std::size_t i = 0; i < objects.data().size(); ++i)
      if (in.ids.data()[i] >= 0.0f)
        objects.data()[i] = static_cast<float>(
            scene.mesh.triangle_object[static_cast<std::size_t>(in.ids.data()[i])]);
    denoise::AtrousOptions denoise_options;
    denoise_options.threads = options.threads;
    in.color = denoise::atrous_filter(in.color, {&out.albedo, &out.normal, &in.depth, &objects},
                                      denoise_options);
    t.denoise_ms = ms_since(t0);
  }

  // A lens that is not plain is drawn by the shaped scatter, which splats the revealed layers'
  // surfaces too. They are found with the round circle of confusion's reach, which holds every
  // shape's bokeh (inscribed in it), but not a tilted plane's: a tilted lens gets none.
  if (method == PreviewMethod::LayeredOcclusion && !in.imaging.lens.aperture.tilted()) {
    // 2. The near-plane id layers and 3. the masks.
    const LayerPlan plan = plan_layers(in.depth, in.imaging, options);
    const int n = plan.size();
    result.coverage = revealed_coverage(plan, in.imaging);
    if (n >= 2) {
      t0 = clock::now();
      IdLayers ids(scene, accel, camera, base, in);
      const std::vector<image::Image> regions =
          lens_reach_regions(in.depth, plan, in.imaging, options, ids.traced_layers(plan));
      std::vector<image::Image> id_layers = ids.render(plan, regions, &t.id_pixels);
      t.id_render_ms = ms_since(t0);
      // No surface at all at or behind the last near plane: any farther plane reveals nothing
      // either, so the revealed layers cover every depth behind z_1.
      if (IdLayers::nothing_seen(id_layers[n - 1]))
        result.coverage.far_depth = std::numeric_limits<double>::infinity();
      t0 = clock::now();
      std::vector<image::Image> masks = build_occlusion_masks(id_layers, regions);
      t.mask_build_ms = ms_since(t0);

      // 4. The revealed layers, where the masks are set.
      t0 = clock::now();
      for (int j = 1; j < n; ++j) {
        std::vector<std::uint32_t> pixels = set_pixels(masks[j]);
        if (pixels.empty()) continue;
        in.revealed.push_back(revealed_layer(scene, accel, camera, base, plan.layers[j].depth,
                                             pixels, std::move(masks[j])));
        t.revealed_pixels += pixels.size();
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
