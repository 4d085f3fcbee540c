#pragma once
// Image integrators over the thin-lens camera:
//   pinhole       every sample through the lens centre (anti-aliased, all in focus);
//   drt           distributed ray tracing (Cook et al. 1984): each sample its own lens point, the
//                 reference method of the paper;
//   accumulation  the accumulation buffer (Haeberli & Akeley 1990, the paper's reference [2]): one
//                 lens point per pass shared by every pixel, passes averaged.
// Rendering is parallel over 16x16 tiles with TBB. Every sample draws its random numbers from
// (seed, pixel, sample index), so a fixed seed gives the same image for any thread count.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "dofcache/cache/radiance_cache.h"
#include "dofcache/cache/sample_radius.h"
#include "dofcache/cache/trace.h"
#include "dofcache/core/progress.h"
#include "dofcache/image/image.h"
#include "dofcache/lens/thin_lens.h"
#include "dofcache/render/adaptive_sampling.h"
#include "dofcache/render/camera.h"
#include "dofcache/render/shading.h"
#include "dofcache/scene/accel.h"
#include "dofcache/scene/scene.h"

namespace dofcache::render {

// Revision of the estimators: raised whenever a change makes images differ for the same seed, so
// that images kept between runs (the benchmarks' converged references) are recomputed. 2: light
// choice by distance (LightSampler) and shadow rays aimed at the light point. 3: a path tracer with
// multiple importance sampling at every vertex and solid-angle sampling of triangle lights.
constexpr int kEstimatorRevision = 3;

enum class Mode { Pinhole, Drt, Accumulation };

// Id of a clipped render's pixel that sees the inside of a closed object (RenderSettings::
// near_depth): no lens ray sees that surface, the object's clipped front lies in front of it.
constexpr float kInsideId = -2.0f;
Mode parse_mode(const std::string& name);  // throws dofcache::Error listing the valid names
const char* mode_name(Mode mode);
const std::vector<std::string>& mode_names();  // "pinhole", "drt", "accumulation"

// The radiance cache of the paper's Algorithm 1, used by `drt` and `accumulation` at primary hits:
// look up E/pi near the hit; on a miss compute it in full and store a sample whose radius follows
// the circle of confusion (eqs. 4.1, 4.2). Rendering then runs in passes of doubling sample counts
// (1, 1, 2, 4, ...): during a pass the cache is read only and new samples go to per-tile buffers
// (a tile reuses its own new samples at once); between passes the buffers are merged in tile order.
// So the image is the same for any thread count. The sample radius: cache/sample_radius.h.
struct CacheSettings {
  cache::RadianceCache* cache = nullptr;  // not owned; null: shade every hit
  cache::RadiusSettings radius;           // how far a new sample may be reused
  cache::LookupOptions lookup;
  // A cache sample is reused by many lens rays, so it is computed with more light and gather
  // samples than a per-ray shade: these multiply ShadingSettings::light_samples / gather_rays.
  // kAutoSampleQuality: effective_sample_quality chooses it from the lens samples per pixel.
  int sample_quality = 4;
  // A cache sample's gather rays are taken again, in doubling rounds up to max_sample_rounds,
  // while their mean's standard error exceeds sample_error times the sample's value
  // (Shader::refined_diffuse_illumination). 1 round: no refinement.
  float sample_error = 0.2f;
  int max_sample_rounds = 8;
  // A sample costs about as much as forty per-ray shades, so it pays only where many lens rays
  // reach it. Hits where fewer than `direct_below` would (spp times the area of the sample's
  // paper radius in pixel footprints, pi r^2, eqs. 4.1-4.2: at a few lens samples in focus) are
  // shaded per ray, with direct_light_samples and direct_gather_rays (the budget the peer
  // benchmark most often finds fastest uncached), and nothing is stored.
  // 0: every hit goes through the cache (the paper; camera paths, whose samples serve many
  // frames). `render` uses kSingleImageDirectBelow.
  float direct_below = 0.0f;
  // In-focus hits (a sample's footprint at most kFocusArea pixel footprints) above direct_below
  // are cached over the first kFocusCostSamples lens samples, and then shaded per ray if their
  // samples' projected rays per lookup exceed `direct_cost_ratio` times a per-ray shade's
  // (focus_cost.h): the choice is measured per render. 0: never (camera paths, the viewer).
  // `render` uses kSingleImageDirectCostRatio.
  float direct_cost_ratio = 0.0f;
  int direct_light_samples = 2, direct_gather_rays = 2;
  std::uint32_t frame = 0;                // stamped on new samples (camera paths)
  bool insert = true;                     // false: use the cache read only
  cache::TraceWriter* trace = nullptr;    // if set, records lookups and inserts for replay
};

// CacheSettings::sample_quality meaning "choose from the lens samples" (the `render` default).
constexpr int kAutoSampleQuality = 0;

// CacheSettings::direct_below for single images: at 4 spp hits with a circle of confusion under 2
// pixels, at 8 under 1.4, from 16 on none (a sample covers at least one pixel footprint there).
// Measured at 320x240 (docs/cache.md, "In focus at a few lens samples"): 1.26-1.30x fewer rays
// at the error of 4 cached lens samples, 1.11-1.15x at that of 8.
constexpr float kSingleImageDirectBelow = 50.0f;

// CacheSettings::direct_cost_ratio for single images: the five small peer scenes measure
// 0.65-1.92 at 16-128 spp (shading their in-focus hits per ray would cost up to 10% more
// error x time, 17-29% on the hanging-light room), the atrium 2.47 at 16 spp (per ray: 3.3x
// faster at a lower error). Cost alone misses the atrium at 64 spp (1.58), whose samples lose on
// quality, not rays (docs/cache.md).
constexpr float kSingleImageDirectCostRatio = 2.0f;

// The footprint, in pixel footprints squared (the sample radius times its squeezed radius), up to
// which a hit counts as in focus for CacheSettings::direct_cost_ratio: a radius of about 1.2
// pixels, a sample's floor (kSingleImageMinFactor, 1) and a little blur.
constexpr double kFocusArea = 1.5;
// The cache sample quality that balances a cached render's two error sources at `spp` lens
// samples per pixel: round(spp / 16) for the default 32 gather rays, clamped to [1, 256]; for
// other gather-ray counts g, that of spp * 32 / g lens samples, so that a cache sample's gather
// rays (quality times g), whose count sets its frozen noise, stay where they would be.
// Why: a pixel averages about k = 8 cache samples (measured: 3.3 samples per pixel footprint under
// the paper radius, each lookup weighting those within half a pixel), so their frozen noise has
// variance V/(q k), V that of one per-ray shade, while the lens rays' own noise falls as 1/spp.
// A q proportional to spp keeps the two in a fixed ratio and the samples' cost (q shades each,
// about 3.3 q per pixel) a fixed fraction of the lens rays'. The factor is measured: spp / 32 was
// the best when the rough specular lobe added most of a lens ray's noise; with that noise
// stratified away (Shader::shade's per-pixel lobe decisions), spp / 16 gives 0-30% lower
// error x time at 32-128 spp on four of the five peer scenes and 12-17% higher on the
// hanging-light room, whose error is the lamp gap's bias, not noise (docs/cache.md).
int recommended_sample_quality(int spp, int gather_rays = ShadingSettings{}.gather_rays);

// The shading of a cache sample: `per_ray` with its light samples and gather rays multiplied by
// `sample_quality` (CacheSettings::sample_quality).
ShadingSettings cache_sample_shading(const ShadingSettings& per_ray, int sample_quality);

struct RenderSettings {
  int width = 640, height = 480;
  int spp = 16;  // samples per pixel (lens samples for drt, passes for accumulation)
  Mode mode = Mode::Drt;
  std::uint64_t seed = 1;
  // Seeds each pixel's film and lens patterns instead of `seed` (unset: `seed`). A camera path's
  // frames share one (the sequence's seed), so a pixel's lens samples do not reshuffle from frame
  // to frame and their error moves with the picture instead of flickering (clean-frames issue).
  std::optional<std::uint64_t> pattern_seed;
  int threads = 0;  // 0: every available core (core/threads.h)
  ShadingSettings shading;
  lens::ThinLens lens;
  // A real lens traced element by element (lens/real_lens.h; none: the thin lens). `lens` is then
  // its thin-lens equivalent (MountedLens::equivalent), which the cache and the preview follow.
  lens::MountedLens real_lens;
  // Camera-space depth of a near clipping plane (0: none). Surfaces nearer are not seen. In the
  // id image of a clipped render, a pixel whose ray first meets the back of a one-sided surface
  // (the inside of a closed object the plane cuts) gets kInsideId.
  float near_depth = 0.0f;
  // If set (1 channel, width x height), only pixels with mask > 0.5 are rendered; others stay
  // black with infinite depth and id -1.
  const image::Image* mask = nullptr;
  // Visibility only (depth, normal, ids through pixel centres): no shading, colour stays black.
  bool visibility_only = false;
  // The id image holds triangle (primitive) ids instead of object ids. The preview's occlusion
  // masks need them to tell a revealed part of an object from its clipped front.
  bool triangle_ids = false;
  CacheSettings cache;
  // Lens samples spread by measured noise (drt only); spp is then the mean per pixel.
  AdaptiveSampling adaptive;
  // Also average the first hit's features over each pixel's lens samples and keep each pixel's
  // sample variance (RenderOutput::lens_features): the guides of the render's denoiser. Adds no
  // rays and changes no colour.
  bool lens_features = false;
  Progress::Display progress = Progress::Display::Auto;
  std::string progress_label = "render";

  void validate() const;  // throws dofcache::Error on absurd values
};

// The cache sample quality a render uses: CacheSettings::sample_quality, or for kAutoSampleQuality
// recommended_sample_quality(spp, gather rays). The one place "auto" is resolved.
int effective_sample_quality(const RenderSettings& settings);

// The shading of hits a cached render shades per ray (CacheSettings::direct_below): the render's
// shading with the cache's direct light samples and gather rays.
ShadingSettings direct_shading(const RenderSettings& settings);

struct RenderStats {
  double seconds = 0.0;
  std::uint64_t camera_rays = 0;
  std::uint64_t rays = 0;            // all rays, including camera rays
  std::uint64_t shading_points = 0;  // full diffuse-illumination evaluations
  int threads = 0;
  // Radiance cache (zero without one). Lookup and insert times are summed over threads; the
  // lookup time is estimated from one lookup in 16.
  std::uint64_t cache_lookups = 0;      // primary hits that needed diffuse illumination
  std::uint64_t cache_hits = 0;         // served by the cache as it was at the start of a pass
  std::uint64_t cache_tile_hits = 0;    // served by samples the same tile made in this pass
  std::uint64_t cache_direct = 0;       // shaded per ray instead (CacheSettings::direct_below)
  std::uint64_t cache_inserted = 0;     // new samples
  std::uint64_t cache_sample_rays = 0;  // rays spent computing them (refinement rounds included)
  // CacheSettings::direct_cost_ratio: the measured ratio (0: not measured) and whether in-focus
  // hits were then shaded per ray.
  double focus_cost_ratio = 0.0;
  bool focus_per_ray = false;
  std::uint64_t cache_samples = 0;      // samples in the cache at the end
  std::uint64_t cache_memory_bytes = 0;
  double cache_lookup_seconds = 0.0;
  double cache_insert_seconds = 0.0;
  int passes = 0;
  double cache_hit_rate() const {
    return cache_lookups ? double(cache_hits + cache_tile_hits) / double(cache_lookups) : 0.0;
  }
  double rays_per_second() const { return seconds > 0 ? rays / seconds : 0.0; }
};

// A pixel's first hits averaged over its lens samples (drt, accumulation): blurred where the
// colour is, by the same lens rays, so a filter guided by them neither sharpens a defocused region
// nor smears an in-focus edge (docs/denoise.md).
struct LensFeatures {
  // RGB: the first hit's base colour (what its diffuse or metallic lobe tints), 0 where a sample
  // met nothing: what the denoiser divides out, so textures are not blurred.
  image::Image albedo;
  image::Image normal;    // RGB: world-space shading normal, 0 where a sample met nothing
  image::Image depth;     // 1 channel: camera-space depth over the samples that hit (+inf: none)
  image::Image coverage;  // 1 channel: the fraction of samples that hit a surface
  // RGB: the radiance the first hits emit towards the camera, and the background where a sample
  // met nothing: the part of the colour whose noise is the lens's and the film's coverage of a
  // lamp or the sky, not the lighting's (a filter treats it apart).
  image::Image emission;
  // RGB: the emission and the albedo where either varies (a lamp's or the sky's edge, in focus or
  // as bokeh; the blur band where a defocused object meets what is behind it) integrated over at
  // least 64 more lens samples, rays that only look at what they hit and need no shading; and
  // the variance of the emission's mean luminance (1 channel). Pixels whose own samples and
  // neighbours all saw one emission and one albedo keep the colour's samples'. The denoiser
  // puts these back in place of `emission` and `albedo` (the raw colour keeps its own samples).
  image::Image emission_estimate;
  image::Image albedo_estimate;
  image::Image emission_variance;
  // 1 channel: the variance of the pixel's mean reflected luminance (the colour less the
  // emission), s^2 / n from its n samples' spread (0 for n = 1). Samples sharing a cache sample
  // are correlated: this misses that part.
  image::Image variance;
  bool empty() const { return albedo.empty(); }
};

struct RenderOutput {
  image::Image color;   // linear RGB
  image::Image depth;   // camera-space depth through the pixel centre (+inf: nothing)
  image::Image normal;  // world-space shading normal through the pixel centre
  image::Image ids;     // object (or triangle) id through the pixel centre (-1: nothing)
  // Diffuse albedo through the pixel centre (RGB; 0: nothing): the denoiser's guide.
  image::Image albedo;
  // With a cache: per pixel, the fraction of lookups the cache served, and the number of samples
  // created there (1 channel each; empty without a cache).
  image::Image cache_hits;
  image::Image cache_density;
  // With adaptive sampling: the lens samples each pixel took (1 channel; else empty).
  image::Image samples;
  LensFeatures lens_features;  // with RenderSettings::lens_features (shaded renders); else empty
  RenderStats stats;
};

ThinLensCamera make_camera(const scene::Camera& camera, const RenderSettings& settings);
// The radiance cache's lookup for a frame seen through `camera`: settings.cache.lookup with the
// anisotropic footprint of an anamorphic aperture (cache::LookupOptions) along the camera's axes.
cache::LookupOptions frame_lookup(const RenderSettings& settings, const ThinLensCamera& camera);

RenderOutput render(const scene::Scene& scene, const scene::Accel& accel,
                    const scene::Camera& camera, const RenderSettings& settings);

// What the ray through the centre of a pixel sees first: render()'s depth and id there.
struct PixelVisibility {
  float depth = 0.0f;  // camera-space depth (+inf: nothing)
  float id = -1.0f;    // object or triangle id (RenderSettings::triangle_ids), -1 or kInsideId
};

// The depth and id images of a visibility-only render(), for the listed pixels only (indices
// y * width + x, in any order; settings.mask is ignored): the same near plane, ids and kInsideId
// rule, bit-identical values (tested). For sparse pixel sets, such as the preview's near-plane id
// layers, it spares render()'s full-size images and tiles. The result follows the list's order.
// Throws dofcache::Error on invalid settings or an index outside the image.
std::vector<PixelVisibility> trace_pixel_centres(const scene::Scene& scene,
                                                 const scene::Accel& accel,
                                                 const scene::Camera& camera,
                                                 const RenderSettings& settings,
                                                 const std::vector<std::uint32_t>& pixels);

// What render() gives at one pixel: colour, and depth and id through its centre.
struct PixelRender {
  glm::vec3 color{0.0f};
  float depth = 0.0f;
  float id = -1.0f;
};

// render() for the listed pixels only (indices y * width + x; settings.mask is ignored), with the
// same values bit for bit (tested): for sparse pixel sets, such as the preview's revealed layers,
// without render()'s full-size buffers. Every mode without a radiance cache, adaptive sampling or
// visibility_only (those throw dofcache::Error, as do invalid settings and indices outside the
// image). The result follows the list's order.
std::vector<PixelRender> render_pixels(const scene::Scene& scene, const scene::Accel& accel,
                                       const scene::Camera& camera,
                                       const RenderSettings& settings,
                                       const std::vector<std::uint32_t>& pixels);

}  // namespace dofcache::render
