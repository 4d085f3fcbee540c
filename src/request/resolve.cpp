#include "dofcache/request/resolve.h"

#include <cmath>
#include <filesystem>

#include <fmt/format.h>
#include <glm/trigonometric.hpp>
#include <nlohmann/json.hpp>

#include "dofcache/cache/radiance_cache.h"
#include "dofcache/core/error.h"
#include "dofcache/image/image_io.h"
#include "dofcache/preview/preview_renderer.h"

namespace dofcache::request {
namespace {

constexpr int kViewSampleQualitySpp = 64;

// The output checks a single image makes before spending time on the render.
void check_image_outputs(const ResolvedRequest& r) {
  check_image_request(r.request);
  r.settings.validate();
  if (!r.preview && !r.request.cache_trace.empty() && r.cache_backend == cache::kNoCache)
    throw Error("--cache-trace needs a cache (--cache octree or vdb)");
}

std::string cache_rule(const RenderRequest& q, bool* uses_cache) {
  if (q.kind == Kind::Sequence) {
    *uses_cache = q.sequence.persistent;
    return q.sequence.persistent ? "a persistent sequence" : "each frame shades every lens ray";
  }
  *uses_cache = integrates_lens(q.mode);
  return *uses_cache ? mode_name(q.mode) + " integrates the lens"
                     : mode_name(q.mode) + " shades each pixel once";
}

// One choice line for a mounted real lens: what the table and the sensor decided, and what of the
// request's lens they replace.
std::string real_lens_choice(const lens::MountedLens& m, const render::LensOverrides& asked) {
  const lens::RealLens& l = *m.lens;
  const glm::dvec2 fov = glm::degrees(m.field_of_view());
  return fmt::format(
      "lens: {}, effective focal length {:.2f} mm, f/{:.2f}{}, focused at {} from the sensor; "
      "field of view {:.2f} x {:.2f} degrees on {:.1f} x {:.1f} mm of the sensor (the camera's "
      "yfov{} ignored)",
      std::filesystem::path(m.source).filename().string(), l.cardinal().focal_length * 1e3,
      l.fstop(), asked.fstop ? "" : " (the table's stop)",
      l.focused_at_infinity() ? std::string("infinity") : fmt::format("{:.3f} m", l.focus_distance()),
      fov.x, fov.y, m.film_size.x * 1e3, m.film_size.y * 1e3,
      asked.focal_length ? " and --focal-length are" : " is");
}

}  // namespace

void check_image_request(const RenderRequest& q) {
  if (q.out.empty()) return;
  const bool preview = q.mode.preview.has_value();
  if (preview && q.cache != "auto" && q.cache != cache::kNoCache)
    throw Error("the preview modes render pinhole images and use no radiance cache "
                "(drop --cache)");
  image::check_output_path(q.out);
  if (!q.preview_inputs.empty()) {
    if (!preview)
      throw Error("--save-preview-inputs needs a preview mode (--mode preview, "
                  "preview-occlusion, preview-gather or preview-scatter)");
    if (!image::is_exr_path(q.preview_inputs))
      throw Error("preview inputs are saved as .exr, not '" + q.preview_inputs + "'");
    image::check_output_path(q.preview_inputs);
  }
  if (!preview && !q.cache_debug.empty()) image::check_output_path(q.cache_debug + "-hits.png");
  if (!preview && !q.cache_trace.empty() && q.cache == cache::kNoCache)
    throw Error("--cache-trace needs a cache (--cache octree or vdb)");
}

ResolvedRequest resolve(const RenderRequest& request, const scene::Scene& scene,
                        const scene::Accel& accel, const scene::Camera& camera) {
  ResolvedRequest r;
  r.request = request;
  RenderRequest& q = r.request;
  auto chose = [&](const std::string& what) { r.choices.push_back(what); };

  if (q.height <= 0) {
    q.height = render::height_for_width(camera, q.width);
    chose("height: " + std::to_string(q.height) + " (the camera's aspect ratio)");
  }
  r.preview = q.mode.preview;
  if (!q.spp) {
    q.spp = r.preview ? preview::kQuickInputSpp : 16;
    chose("spp: " + std::to_string(*q.spp) + (r.preview ? " (quick preview inputs)" : ""));
  }
  if (!q.shading) {
    q.shading = r.preview ? preview::quick_input_shading(render::ShadingSettings{}, true)
                          : render::ShadingSettings{};
    if (r.preview) chose("shading: quick preview inputs (1 light sample, 2 gather rays)");
  }
  if (q.cache == "auto") {
    bool uses_cache = false;
    const std::string why = cache_rule(q, &uses_cache);
    q.cache = uses_cache ? cache::kDefaultCacheBackend : cache::kNoCache;
    chose("cache: auto -> " + q.cache + " (" + why + ")");
  }
  cache::check_radiance_cache_backend(q.cache, /*allow_none=*/true);
  if (q.kind == Kind::Sequence && q.sequence.persistent && q.cache == cache::kNoCache)
    throw Error("--persistent needs a cache (--cache octree or vdb)");
  r.cache_backend = q.cache;
  if (q.adaptive == Choice::Auto) {
    const bool on = q.kind != Kind::Sequence && !r.preview && q.mode.integrator == render::Mode::Drt;
    q.adaptive = on ? Choice::On : Choice::Off;
    chose(std::string("adaptive: auto -> ") + choice_name(q.adaptive));
  }

  render::RenderSettings& s = r.settings;
  s.width = q.width;
  s.height = q.height;
  s.spp = *q.spp;
  s.mode = r.preview ? render::Mode::Pinhole : q.mode.integrator;
  s.seed = q.seed;
  s.pattern_seed = q.pattern_seed;
  s.threads = resolve_threads(q.threads, q.core_policy);
  s.shading = *q.shading;
  r.environment = render::resolve_environment(q.environment, scene, q.limits);
  s.shading.environment = r.environment.environment;
  s.cache = q.cache_settings;
  s.cache.cache = nullptr;
  s.cache.trace = nullptr;
  if (s.cache.sample_quality == render::kAutoSampleQuality) {
    // The viewer's passes share one cache, so its samples are shaded for many passes: for 64
    // lens samples, as the reference mostly is by the time a user looks at it.
    s.cache.sample_quality =
        q.kind == Kind::View
            ? render::recommended_sample_quality(kViewSampleQualitySpp, s.shading.gather_rays)
            : render::effective_sample_quality(s);
    q.cache_settings.sample_quality = s.cache.sample_quality;
    if (q.cache != cache::kNoCache)
      chose("cache sample quality: " + std::to_string(s.cache.sample_quality) + " (from " +
            std::to_string(s.spp) + " spp)");
  }
  s.adaptive = q.adaptive_settings;
  s.adaptive.enabled = q.adaptive == Choice::On;
  s.progress = q.quiet ? Progress::Display::Never : Progress::Display::Auto;

  const render::ResolvedLens lens =
      render::resolve_lens(scene, accel, camera, q.lens, s.width, s.height);
  s.lens = lens.lens;
  s.real_lens = lens.mounted;
  // An aperture image is read here once, so an unreadable one is refused before the render.
  if (!s.lens.aperture.image.empty()) lens::Aperture{s.lens.aperture};
  r.focus_from_scene = lens.focus_from_scene;
  if (s.real_lens) {
    chose(real_lens_choice(s.real_lens, q.lens));
    const double distortion = s.real_lens.corner_distortion();
    if (r.preview && !(distortion <= preview::kMaxPreviewDistortion))
      throw Error("the preview draws a perspective projection and " +
                  std::filesystem::path(s.real_lens.source).filename().string() +
                  " is far from one (" +
                  (std::isfinite(distortion) ? fmt::format("{:.0f} %", 100.0 * distortion)
                                             : std::string("90 degrees or more")) +
                  " at the frame's corner: a fisheye); render it with --mode drt");
  }
  // A sequence's lens may change per frame (its path's keys): only images fix it here.
  if (q.kind != Kind::Sequence) {
    if (r.focus_from_scene) chose("focus: autofocus on the image centre");
    if (s.real_lens) {
      // The lens file sets the focal length; the focus is the sensor's distance.
      q.lens.focal_length.reset();
      q.lens.fstop = s.real_lens.lens->fstop();
      q.lens.focus_distance = s.real_lens.lens->focus_distance();
    } else {
      q.lens.focal_length = s.lens.focal_length;
      q.lens.fstop = s.lens.fstop;
      q.lens.focus_distance = s.lens.focus_distance;
      q.lens.aperture = {};
      // The shape as resolved (command line, then extras.lens); round stays unset.
      if (!s.lens.aperture.plain()) q.lens.aperture = lens::ApertureChoices::of(s.lens.aperture);
    }
  }

  if (q.kind == Kind::Sequence && q.sequence.temporal > 0) {
    // The temporal filter reads each frame's denoised colour and its guides back from the EXR.
    SequenceChoices& t = q.sequence;
    if (q.denoise == Choice::Off)
      throw Error("--temporal filters the denoised frames: drop --denoise off");
    if (!image::is_exr_path(q.out))
      throw Error("--temporal reads the frames' feature layers back: write the frames as EXR "
                  "(e.g. --out frames/####.exr) and the filtered ones to --temporal-output "
                  "(PNG or EXR)");
    if (q.denoise == Choice::Auto) {
      q.denoise = Choice::On;
      chose("denoise: auto -> on (--temporal filters the denoised frames)");
    }
    if (t.temporal_output.empty()) {
      const std::filesystem::path out(q.out);
      t.temporal_output =
          (out.parent_path() / (out.stem().string() + ".temporal" + out.extension().string()))
              .string();
      chose("temporal output: " + t.temporal_output);
    }
  } else if (q.kind == Kind::Sequence && q.sequence.temporal_only) {
    throw Error("--temporal-only needs --temporal N (frames on each side)");
  }
  if (q.denoise == Choice::Auto) {
    // An 8-bit image is for looking at: it gets the denoised colour. An EXR is for further work
    // (compositing, references): its beauty stays the raw, unbiased render.
    const bool png_image = q.kind != Kind::View && !q.out.empty() && !image::is_exr_path(q.out);
    q.denoise = r.preview || q.kind == Kind::View || png_image ? Choice::On : Choice::Off;
    chose(std::string("denoise: auto -> ") + choice_name(q.denoise) +
          (r.preview || q.kind == Kind::View ? " (the pinhole inputs)"
           : png_image                      ? " (a PNG shows the denoised render)"
           : !q.out.empty()                 ? " (an EXR keeps the raw render)"
                                            : ""));
  }
  r.preview_options.denoise = q.denoise == Choice::On;
  // The integrators' renders keep the lens features their denoiser needs (request::denoised).
  s.lens_features = q.denoise == Choice::On && !r.preview && q.kind != Kind::View;
  r.preview_options.threads = s.threads;
  r.preview_options.layer_composite = q.composite;
  r.preview_options.edge_rays = q.edge_rays;
  if (q.kind == Kind::Image && !q.out.empty()) check_image_outputs(r);
  return r;
}

nlohmann::json resolved_json(const ResolvedRequest& resolved) {
  nlohmann::json j = to_json(resolved.request);
  j["choices"] = resolved.choices;
  return j;
}

}  // namespace dofcache::request
