#include "dofcache/request/image_render.h"

#include <algorithm>
#include <memory>

#include <fmt/format.h>

#include "dofcache/cache/radiance_cache.h"
#include "dofcache/cache/trace.h"
#include "dofcache/core/atomic_file.h"
#include "dofcache/core/error.h"
#include "dofcache/core/stopwatch.h"
#include "dofcache/denoise/render_filter.h"
#include "dofcache/image/image_io.h"
#include "dofcache/image/metrics.h"
#include "dofcache/lens/lens_identity.h"
#include "dofcache/lens/lens_json.h"
#include "dofcache/preview/inputs_file.h"

namespace dofcache::request {
namespace {

using nlohmann::json;

// What every image's statistics begin with.
json common_stats(const ResolvedRequest& r, const scene::Scene& scene,
                  const scene::Camera& camera) {
  const render::RenderSettings& s = r.settings;
  return {{"scene", scene.source},
          {"camera", camera.name},
          {"width", s.width},
          {"height", s.height},
          {"spp", s.spp},
          {"seed", s.seed},
          {"lens", lens::lens_json(s.lens)},
          {"real_lens", s.real_lens ? lens::real_lens_json(s.real_lens) : json(nullptr)},
          {"shading", shading_json(s.shading)},
          {"environment", environment_json(r.request.environment, r.environment)},
          {"output", r.request.out}};
}

ImageResult render_preview_image(const ResolvedRequest& r, const scene::Scene& scene,
                                 const scene::Accel& accel, const scene::Camera& camera) {
  const RenderRequest& q = r.request;
  ImageResult result;
  result.preview = preview::render_scene_preview(scene, accel, camera, r.settings, *r.preview,
                                                 r.preview_options);
  const preview::ScenePreview& p = *result.preview;
  image::write_image(q.out, p.image, {{{"Z"}, p.inputs.depth}, {{"id"}, p.inputs.ids}});
  if (!q.preview_inputs.empty())
    preview::save_preview_inputs(q.preview_inputs, p.inputs, p.coverage, r.preview_options);
  const preview::ScenePreviewTimings& t = p.timings;
  result.stats = common_stats(r, scene, camera);
  result.stats.update(
      {{"mode", mode_name(q.mode)},
       {"method", preview::preview_method_name(*r.preview)},
       {"threads", t.pinhole_stats.threads},
       {"seconds", t.total_ms * 1e-3},
       {"preview",
        {{"layers", t.layers}, {"revealed_layers", t.revealed_layers},
         {"revealed_pixels", t.revealed_pixels}, {"id_pixels", t.id_pixels},
         {"pinhole_render_ms", t.pinhole_render_ms}, {"id_render_ms", t.id_render_ms},
         {"mask_build_ms", t.mask_build_ms}, {"extra_region_mask_ms", t.mask_ms()},
         {"extra_render_ms", t.extra_render_ms}, {"postprocess_ms", t.postprocess_ms},
         {"total_ms", t.total_ms}, {"shaped_bokeh", t.postprocess.shaped_bokeh}}}});
  if (r.preview_options.denoise) result.stats["preview"]["denoise_ms"] = t.denoise_ms;
  return result;
}

}  // namespace

void write_render(const std::string& path, const render::RenderOutput& out,
                  const std::optional<image::Image>& denoised, const lens::MountedLens& real_lens) {
  std::vector<image::NamedChannels> layers = {
      {{"Z"}, out.depth}, {{"N.X", "N.Y", "N.Z"}, out.normal}, {{"id"}, out.ids}};
  const auto attributes =
      real_lens ? lens::real_lens_attributes(real_lens) : std::map<std::string, std::string>{};
  if (!denoised) return image::write_image(path, out.color, layers, attributes);
  if (!image::is_exr_path(path)) return image::write_image(path, *denoised, layers);
  const render::LensFeatures& f = out.lens_features;
  layers.insert(layers.end(), {{{"denoised.R", "denoised.G", "denoised.B"}, *denoised},
                               {{"albedo.R", "albedo.G", "albedo.B"}, f.albedo_estimate},
                               {{"lens.N.X", "lens.N.Y", "lens.N.Z"}, f.normal},
                               {{"lens.Z"}, f.depth},
                               {{"lens.coverage"}, f.coverage},
                               {{"emission.R", "emission.G", "emission.B"}, f.emission},
                               {{"emission_estimate.R", "emission_estimate.G",
                                 "emission_estimate.B"},
                                f.emission_estimate},
                               {{"emission_variance.Y"}, f.emission_variance},
                               {{"variance.Y"}, f.variance}});
  image::write_image(path, out.color, layers, attributes);
}

image::Image denoised(const render::RenderOutput& out, const render::RenderSettings& settings,
                      const scene::Camera& camera) {
  const render::LensFeatures& f = out.lens_features;
  if (f.empty()) throw Error("denoise: the render kept no lens features");
  const image::Image coc =
      settings.mode == render::Mode::Pinhole
          ? image::Image(out.color.width(), out.color.height(), 1, 0.0f)
          : denoise::coc_radius_image(out.depth, f.depth,
                                      render::make_camera(camera, settings).imaging());
  denoise::RenderFilterOptions options;
  options.threads = settings.threads;
  return denoise::render_filter(
      out.color, {&f.albedo, &f.albedo_estimate, &f.normal, &f.coverage, &f.emission,
                  &f.emission_estimate, &f.emission_variance, &f.variance, &out.depth, &out.ids,
                  &coc},
      options);
}

json environment_json(const render::EnvironmentSettings& settings,
                      const render::ResolvedEnvironment& environment) {
  const render::Environment* e = environment.environment.get();
  const char* kind = !e                        ? "none"
                     : environment.default_sky ? "default_sky"
                     : e->is_constant()        ? "constant"
                                               : "map";
  json j = {{"kind", kind}, {"description", environment.description}};
  if (e) {
    const glm::vec3 m = e->mean_radiance();
    j.update({{"strength", settings.strength},
              {"rotation_deg", e->rotation() * 57.29577951f},
              {"visible", e->visible()},
              {"mean_radiance", {m.x, m.y, m.z}}});
    if (!settings.path.empty()) j["path"] = settings.path;
  }
  return j;
}

std::string describe_setup(const ResolvedRequest& r, const scene::Scene& scene,
                           const scene::Camera& camera) {
  const lens::ThinLens& l = r.settings.lens;
  std::string text = fmt::format("scene   {}: {} triangles, {} emissive, {} punctual lights\n",
                                 scene.source, scene.mesh.triangles.size(),
                                 scene.emitters.size(), scene.lights.size());
  if (r.environment.environment) text += "env     " + r.environment.description + "\n";
  if (camera.synthesized)
    text += "notice  the scene has no camera; using one that frames its bounds\n";
  const char* autofocus = r.focus_from_scene ? " (autofocus on the image centre)" : "";
  if (const lens::MountedLens& m = r.settings.real_lens) {
    if (r.preview) text += std::string("notice  ") + preview::kRealLensPreviewNotice + "\n";
    const lens::RealLens& real = *m.lens;
    text += fmt::format("camera  '{}', lens {} ({:.1f} mm f/{:.3g}), focus {} from the sensor{}\n",
                        camera.name, m.source, real.cardinal().focal_length * 1000.0,
                        real.fstop(),
                        real.focused_at_infinity() ? std::string("at infinity")
                                                   : fmt::format("{:.3g} m", real.focus_distance()),
                        autofocus);
  } else {
    text += fmt::format("camera  '{}', lens {:.0f} mm f/{:.3g}, focus {:.3g} m (aperture "
                        "{:.3g} mm){}\n",
                        camera.name, l.focal_length * 1000.0, l.fstop, l.focus_distance,
                        l.aperture_diameter() * 1000.0, autofocus);
  }
  // A real lens's equivalent carries its stop's shape (lens/real_lens.h).
  const lens::ApertureShape& a = l.aperture;
  if (a.plain()) return text;
  text += "        aperture " + lens::describe_aperture(a) + "\n";
  if (r.preview) text += std::string("notice  ") + preview::kShapedPreviewNotice + "\n";
  return text;
}

std::string describe(const ResolvedRequest& r, const ImageResult& result) {
  const render::RenderSettings& s = r.settings;
  if (result.preview) {
    const preview::ScenePreviewTimings& t = result.preview->timings;
    std::string text = fmt::format("preview {}x{} {}, {} pinhole spp, {} layers", s.width,
                                   s.height, preview::preview_method_name(*r.preview), s.spp,
                                   t.layers);
    if (*r.preview == preview::PreviewMethod::LayeredOcclusion)
      text += fmt::format(" ({} revealed, {} px rendered again)", t.revealed_layers,
                          t.revealed_pixels);
    return text + fmt::format(": {:.2f} s\n        pinhole {:.1f} ms, extra-region mask {:.1f} "
                              "ms, extra render {:.1f} ms, post-process {:.1f} ms\n",
                              t.total_ms * 1e-3, t.pinhole_render_ms, t.mask_ms(),
                              t.extra_render_ms, t.postprocess_ms);
  }
  const render::RenderStats& st = result.render->stats;
  std::string text = fmt::format(
      "render  {}x{} {}, {} spp, {} threads: {:.2f} s, {:.2f} M rays/s ({:.1f} M rays)\n",
      s.width, s.height, render::mode_name(s.mode), s.spp, st.threads, st.seconds,
      st.rays_per_second() * 1e-6, st.rays * 1e-6);
  if (result.denoised)
    text += fmt::format("denoise lens-aware a-trous filter: {:.2f} s{}\n", result.denoise_seconds,
                        image::is_exr_path(r.request.out)
                            ? " (the EXR's beauty stays raw; denoised.RGB beside it)"
                            : "");
  if (r.cache_backend == cache::kNoCache) return text;
  return text + fmt::format(
                    "cache   {}: {:.1f}% of {} lookups served ({:.1f}% from earlier passes), {} "
                    "samples, {:.2f} MB, lookup {:.2f} s, insert {:.3f} s (thread-seconds); {} "
                    "hits shaded per ray\n",
                    r.cache_backend, 100.0 * st.cache_hit_rate(), st.cache_lookups,
                    st.cache_lookups ? 100.0 * st.cache_hits / st.cache_lookups : 0.0,
                    st.cache_samples, st.cache_memory_bytes / 1e6, st.cache_lookup_seconds,
                    st.cache_insert_seconds, st.cache_direct);
}

ImageResult render_image(const ResolvedRequest& r, const scene::Scene& scene,
                         const scene::Accel& accel, const scene::Camera& camera) {
  const RenderRequest& q = r.request;
  ImageResult result;
  if (r.preview) {
    result = render_preview_image(r, scene, accel, camera);
  } else {
    render::RenderSettings s = r.settings;
    std::unique_ptr<cache::RadianceCache> radiance_cache =
        cache::make_radiance_cache(r.cache_backend);
    s.cache.cache = radiance_cache.get();
    std::unique_ptr<cache::TraceWriter> trace;
    if (!q.cache_trace.empty()) {
      trace = std::make_unique<cache::TraceWriter>(
          q.cache_trace, render::frame_lookup(s, render::make_camera(camera, s)));
      s.cache.trace = trace.get();
    }
    result.render = render::render(scene, accel, camera, s);
    const render::RenderOutput& out = *result.render;
    if (s.lens_features) {
      const Stopwatch clock;
      result.denoised = denoised(out, s, camera);
      result.denoise_seconds = clock.seconds();
    }
    write_render(q.out, out, result.denoised, r.settings.real_lens);
    if (trace) trace->close();
    if (!q.cache_debug.empty() && radiance_cache) {
      double max_density = 1.0;
      for (float v : out.cache_density.data()) max_density = std::max<double>(max_density, v);
      image::write_image(q.cache_debug + "-hits.png", image::false_color(out.cache_hits, 1.0));
      image::write_image(q.cache_debug + "-density.png",
                         image::false_color(out.cache_density, max_density));
    }
    const render::RenderStats& st = out.stats;
    result.stats = common_stats(r, scene, camera);
    result.stats.update(
        {{"mode", render::mode_name(s.mode)},
         {"adaptive", s.adaptive.enabled && render::pilot_samples(s.adaptive, s.spp) > 0},
         {"threads", st.threads},
         {"seconds", st.seconds},
         {"camera_rays", st.camera_rays},
         {"rays", st.rays},
         {"rays_per_second", st.rays_per_second()},
         {"shading_points", st.shading_points},
         {"cache", cache_json(r.cache_backend, s.cache)}});
    result.stats["cache"].update(
        {{"lookups", st.cache_lookups}, {"hits", st.cache_hits},
         {"tile_hits", st.cache_tile_hits}, {"hit_rate", st.cache_hit_rate()},
         {"direct", st.cache_direct}, {"inserted", st.cache_inserted},
         {"sample_rays", st.cache_sample_rays},
         {"focus_cost_ratio", st.focus_cost_ratio}, {"focus_per_ray", st.focus_per_ray},
         {"samples", st.cache_samples}, {"memory_bytes", st.cache_memory_bytes},
         {"lookup_seconds", st.cache_lookup_seconds},
         {"insert_seconds", st.cache_insert_seconds}, {"passes", st.passes}});
    if (result.denoised)
      result.stats["denoise"] = {
          {"filter", "render_filter"},
          {"seconds", result.denoise_seconds},
          {"beauty", image::is_exr_path(q.out) ? "raw (denoised.RGB beside it)" : "denoised"}};
  }
  if (!q.stats_json.empty()) write_bytes_atomically(q.stats_json, result.stats.dump(2) + "\n");
  return result;
}

}  // namespace dofcache::request
