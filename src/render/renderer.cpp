#include "dofcache/render/renderer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <thread>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "dofcache/cache/sample_radius.h"
#include "dofcache/cache/tile_buffer.h"
#include "dofcache/core/error.h"
#include "dofcache/core/stopwatch.h"
#include "dofcache/core/threads.h"
#include "dofcache/render/adaptive_sampling.h"
#include "dofcache/render/focus_cost.h"
#include "dofcache/render/sampler.h"

namespace dofcache::render {
namespace {

constexpr int kTileSize = 16;
constexpr int kTimedLookupEvery = 16;

struct Tile {
  int x0, y0, x1, y1;
};

std::vector<Tile> make_tiles(int width, int height) {
  std::vector<Tile> tiles;
  for (int y = 0; y < height; y += kTileSize)
    for (int x = 0; x < width; x += kTileSize)
      tiles.push_back({x, y, std::min(x + kTileSize, width), std::min(y + kTileSize, height)});
  return tiles;
}

bool masked_out(const RenderSettings& s, int x, int y) {
  return s.mask && s.mask->at(x, y, 0) <= 0.5f;
}

// How a cached render shades in-focus hits (CacheSettings::direct_cost_ratio): measured first,
// where a tile samples the cost (TileWork::samples_focus) through the cache and elsewhere per ray;
// then all through the cache or all per ray.
enum class FocusState { Measuring, Cached, PerRay };

// While measuring, the tiles of one tile row in kFocusSampleRows, counted from the middle row, go
// through the cache (the others measure the per-ray shades' cost): on the atrium the in-focus
// samples of 2 lens samples cost as much as a whole 16-spp per-ray render.
constexpr int kFocusSampleRows = 16;

// Everything a render needs that is fixed for its duration (but for the in-focus choice).
struct Context {
  const scene::Scene& scene;
  const scene::Accel& accel;
  const RenderSettings& settings;
  ThinLensCamera camera;
  Shader shader;
  Shader sample_shader;  // for cache samples: more light and gather samples
  Shader direct_shader;  // for hits too few lens rays would reuse (CacheSettings::direct_below)
  cache::LookupOptions lookup;  // frame_lookup: the cache's lookup for this camera
  // Adaptive lens sampling: each pixel's sample count (null: settings.spp everywhere), and the
  // pilot's luminance moments to fill (null: none kept). A pixel is written by its own tile only.
  const std::uint32_t* pixel_samples = nullptr;
  PixelMoments* moments = nullptr;
  // RenderSettings::lens_features: per pixel, kFeatureSums sums (null: none kept).
  double* feature_sums = nullptr;
  // CacheSettings::direct_cost_ratio: how in-focus hits are shaded (FocusState).
  FocusState focus = FocusState::Cached;
};

// The sums kept per pixel for RenderSettings::lens_features: albedo (3), normal (3), depth over
// the hits, hits, the reflected luminance and its square, emission (3), the emitted luminance and
// its square, the albedo's luminance squared.
constexpr int kFeatureSums = 16;

// The first hit of one lens sample, for the lens features.
struct SampleFeatures {
  bool hit = false;
  glm::vec3 albedo{0.0f}, normal{0.0f};
  glm::vec3 emission{0.0f};  // what the first hit emits, or the background the ray meets
  float depth = 0.0f;
};

// Per-pixel cache statistics (debug images); each pixel is written by its own tile only.
struct PixelCacheStats {
  image::Image lookups, hits, created;
  bool enabled() const { return !lookups.empty(); }
};

// What one tile accumulates during one pass.
struct TileWork {
  RayCounters rays;
  cache::TileSampleBuffer buffer;  // samples created by this tile in this pass
  std::vector<cache::TraceLookup> traced;
  std::uint64_t lookups = 0, hits = 0, tile_hits = 0, direct = 0;
  std::uint64_t sample_rays = 0;  // rays spent computing new samples
  FocusCost focus;                // what the in-focus hits' new samples cost
  bool samples_focus = false;     // while FocusState::Measuring, cache in-focus hits here
  double lookup_seconds = 0.0;
};

// Throws unless every pixel index (y * width + x) lies inside the image; `what` names the caller.
void check_pixel_indices(const RenderSettings& settings, const std::vector<std::uint32_t>& pixels,
                         const char* what) {
  const std::uint64_t count = static_cast<std::uint64_t>(settings.width) * settings.height;
  for (std::uint32_t p : pixels)
    if (p >= count) throw Error(std::string(what) + ": pixel index outside the image");
}

scene::Ray clipped(const ThinLensCamera& camera, const RenderSettings& settings, scene::Ray ray) {
  if (settings.near_depth > 0.0f) {
    ray.tnear = camera.t_at_depth(ray, settings.near_depth);
    // The inside of an object the plane cuts open is what a clipped render is for: the back
    // faces glTF would cull stay visible (and are marked kInsideId in the ids).
    ray.cull_back_faces = false;
  }
  return ray;
}

// Algorithm 1 of the paper: E/pi at a primary hit from the cache, or computed and stored.
glm::vec3 cached_diffuse(const Context& c, const ShadingPoint& p, std::uint64_t key, Rng& rng,
                         TileWork& work, float* density, bool in_focus) {
  const CacheSettings& cs = c.settings.cache;
  const glm::vec3 x = p.surface.position;
  ++work.lookups;
  if (cs.trace) work.traced.push_back({x, p.n});
  cache::LookupResult r;
  // One lookup in kTimedLookupEvery is timed: reading the clock costs a good part of a lookup.
  const bool timed = work.lookups % kTimedLookupEvery == 0;
  auto t0 = timed ? std::chrono::steady_clock::now() : std::chrono::steady_clock::time_point{};
  bool hit = cs.cache->lookup(x, p.n, c.lookup, &r);
  if (!hit && cs.insert) {
    hit = work.buffer.lookup(x, p.n, c.lookup, &r);
    work.tile_hits += hit;
  } else {
    work.hits += hit;
  }
  if (timed) work.lookup_seconds += kTimedLookupEvery * seconds_since(t0);
  work.focus.lookups += in_focus;
  if (hit) return r.value;
  float harmonic = 0.0f;
  const std::uint64_t rays_before = work.rays.rays;
  glm::vec3 e = c.sample_shader.refined_diffuse_illumination(
      p, key, rng, work.rays, &harmonic, cs.sample_error, cs.max_sample_rounds);
  const std::uint64_t rays = work.rays.rays - rays_before;
  work.sample_rays += rays;
  if (in_focus) ++work.focus.samples, work.focus.rays += rays;
  if (cs.insert) {
    cache::CacheSample sample;
    sample.position = x;
    sample.normal = p.n;
    sample.value = e;
    // Gather rays measure how near the geometry is, not how near the lights are: next to a lamp,
    // direct light changes as 1/d^2 while the surroundings may be far, so the adaptive rule's
    // smooth distance is also bounded by the distance to the nearest light.
    double smooth = 0.0;
    if (cs.radius.rule == cache::RadiusRule::Adaptive)
      smooth = std::min(static_cast<double>(harmonic),
                        static_cast<double>(c.shader.light_sampler().nearest_light_distance(x)));
    sample.radius =
        cache::new_sample_radius(cs.radius, c.camera.imaging_at(x), c.camera.depth(x), smooth).radius;
    sample.frame = cs.frame;
    work.buffer.add(sample);
    if (density) *density += 1.0f;
  }
  return e;
}

// How a cached render shades a hit.
// The in-focus kinds are counted while FocusState::Measuring.
enum class HitShading { Cached, CachedInFocus, PerRay, PerRayInFocus };

// CacheSettings::direct_below: a sample made at x would be reached by about spp * pi r r' lens
// rays, r its radius in pixel footprints and r' its squeezed one; below the threshold the hit is
// shaded per ray. In focus (kFocusArea), CacheSettings::direct_cost_ratio decides (FocusState).
HitShading hit_shading(const Context& c, const TileWork& work, glm::vec3 x) {
  const CacheSettings& cs = c.settings.cache;
  if (cs.direct_below <= 0.0f && cs.direct_cost_ratio <= 0.0f) return HitShading::Cached;
  const double r =
      cache::sample_radius_pixels(c.camera.imaging(), c.camera.depth(x), cs.radius.min_factor);
  // An anamorphic footprint is an oval: its smaller semi-axis is squeezed down to the floor.
  const double squeeze = c.lookup.footprint_squeeze;
  const double area = r * std::max(r * squeeze, cs.radius.min_factor);
  if (c.settings.spp * M_PI * area < cs.direct_below) return HitShading::PerRay;
  if (area > kFocusArea) return HitShading::Cached;
  switch (c.focus) {
    case FocusState::Measuring:
      return work.samples_focus ? HitShading::CachedInFocus : HitShading::PerRayInFocus;
    case FocusState::PerRay: return HitShading::PerRay;
    case FocusState::Cached: break;
  }
  return HitShading::Cached;
}

// The albedo the denoiser demodulates by: what the diffuse lobe reflects.
glm::vec3 guide_albedo(const RenderSettings& settings, const scene::MaterialPoint& m) {
  return settings.shading.material_override == MaterialOverride::Lambert ? m.base_color
                                                                         : m.diffuse_albedo();
}

// Radiance along one camera ray; `features`, if set, receives its first hit.
glm::vec3 trace_camera_ray(const Context& c, const scene::Ray& ray, std::uint64_t key, float lobe_u,
                           Rng& rng, TileWork& work, float* density, SampleFeatures* features) {
  ++work.rays.rays;
  scene::Hit hit = c.accel.intersect(ray);
  if (!hit.valid()) {
    const glm::vec3 b = c.shader.background(ray.direction);
    if (features) features->emission = b;
    return b;
  }
  ShadingPoint p = c.shader.prepare(ray, hit);
  if (features) {
    features->hit = true;
    features->albedo = p.material.base_color;
    features->normal = p.surface.shading_normal;
    features->emission = c.shader.emitted(p);
    features->depth = static_cast<float>(c.camera.depth(p.surface.position));
  }
  glm::vec3 e(0.0f);
  if (Shader::has_diffuse(p)) {
    if (!c.settings.cache.cache) {
      e = c.shader.diffuse_illumination(p, key, rng, work.rays);
    } else {
      const HitShading how = hit_shading(c, work, p.surface.position);
      if (how == HitShading::PerRay || how == HitShading::PerRayInFocus) {
        ++work.direct;
        const std::uint64_t before = work.rays.rays;
        e = c.direct_shader.diffuse_illumination(p, key, rng, work.rays);
        if (how == HitShading::PerRayInFocus)
          ++work.focus.direct_shades, work.focus.direct_rays += work.rays.rays - before;
      } else {
        e = cached_diffuse(c, p, key, rng, work, density, how == HitShading::CachedInFocus);
      }
    }
  }
  return c.shader.shade(p, e, lobe_u, rng, work.rays);
}

// Where the samples of one pixel fall on the film and on the lens: the pixel's two Sobol
// patterns, their scrambles derived once for all its samples.
class PixelSamples {
 public:
  PixelSamples(const RenderSettings& st, int x, int y)
      : pixel_(x, y),
        mode_(st.mode),
        film_(pixel_key(st.pattern_seed.value_or(st.seed), x, y, Dimension::Film)),
        // Accumulation: one lens point per pass, shared by all pixels.
        lens_(st.mode == Mode::Accumulation
                  ? hash_combine(st.pattern_seed.value_or(st.seed),
                                 static_cast<std::uint64_t>(Dimension::Lens))
                  : pixel_key(st.pattern_seed.value_or(st.seed), x, y, Dimension::Lens)) {}

  glm::vec2 film(std::uint32_t s) const { return pixel_ + film_(s); }
  // Sample s's camera ray. The pinhole mode looks through the lens's centre alone, past the
  // aperture's shape, the stop and the colour bands (a preview draws those itself).
  LensSample ray(const ThinLensCamera& camera, std::uint32_t s, int band = -1) const {
    if (mode_ == Mode::Pinhole) return {camera.pinhole_ray(film(s)), 1.0f};
    return camera.lens_ray(film(s), lens_(s), band);
  }
  // ray(camera, s0 + i, band[i]) for i in [0, n), n <= kBlock: the lens rays together
  // (ThinLensCamera::lens_rays traces a real lens's several at a time).
  static constexpr std::uint32_t kBlock = 16;
  void rays(const ThinLensCamera& camera, std::uint32_t s0, std::uint32_t n, const int* band,
            LensSample* out) const {
    if (mode_ == Mode::Pinhole) {
      for (std::uint32_t i = 0; i < n; ++i) out[i] = ray(camera, s0 + i);
      return;
    }
    glm::vec2 films[kBlock], lens[kBlock];
    for (std::uint32_t i = 0; i < n; ++i) films[i] = film(s0 + i), lens[i] = lens_(s0 + i);
    camera.lens_rays(n, films, lens, band, out);
  }

 private:
  glm::vec2 pixel_;
  Mode mode_;
  Sobol2D film_, lens_;
};

// What the ray through the centre of pixel (x, y) sees first (render()'s depth, normal and id).
struct CentreHit {
  bool hit = false;
  float depth = 0.0f, id = -1.0f;
  glm::vec3 normal{0.0f};
  glm::vec3 albedo{0.0f};
};

CentreHit trace_centre(const scene::Scene& scene, const scene::Accel& accel,
                       const ThinLensCamera& camera, const RenderSettings& settings, int x, int y,
                       RayCounters& counters) {
  scene::Ray ray = clipped(camera, settings, camera.pinhole_ray(glm::vec2(x + 0.5f, y + 0.5f)));
  ++counters.rays;
  scene::Hit hit = accel.intersect(ray);
  CentreHit r;
  if (!hit.valid()) return r;
  scene::SurfacePoint sp = scene.surface_point(hit.triangle, hit.u, hit.v);
  r.hit = true;
  r.depth = camera.depth(sp.position);
  r.normal = sp.shading_normal;
  r.albedo = guide_albedo(settings, scene.material_at(sp));
  r.id = static_cast<float>(settings.triangle_ids ? hit.triangle
                                                  : scene.mesh.triangle_object[hit.triangle]);
  // glTF culls the back of one-sided surfaces: met first behind a near plane, it is the inside
  // of an object whose front the plane removed.
  if (settings.near_depth > 0.0f && glm::dot(sp.geometric_normal, ray.direction) > 0.0f &&
      !scene.materials[sp.material].double_sided)
    r.id = kInsideId;
  return r;
}

void render_aovs(const Context& c, const Tile& t, RenderOutput& out, RayCounters& counters) {
  for (int y = t.y0; y < t.y1; ++y)
    for (int x = t.x0; x < t.x1; ++x) {
      if (masked_out(c.settings, x, y)) continue;
      const CentreHit h = trace_centre(c.scene, c.accel, c.camera, c.settings, x, y, counters);
      if (!h.hit) continue;
      out.depth.at(x, y, 0) = h.depth;
      float* n = out.normal.pixel(x, y);
      n[0] = h.normal.x, n[1] = h.normal.y, n[2] = h.normal.z;
      out.ids.at(x, y, 0) = h.id;
      float* a = out.albedo.pixel(x, y);
      a[0] = h.albedo.x, a[1] = h.albedo.y, a[2] = h.albedo.z;
    }
}

// Chromatic aberration (lens/aperture.h): the pixel's band key, and a sample's radiance in its
// band's channel alone, three times over (a third of the samples carry each band).
std::uint64_t band_key(const RenderSettings& st, int x, int y) {
  return pixel_key(st.pattern_seed.value_or(st.seed), x, y, Dimension::Band);
}

glm::vec3 in_band(glm::vec3 l, int band) {
  glm::vec3 only(0.0f);
  only[band] = 3.0f * l[band];
  return only;
}

// Whether samples carry colour bands (chromatic aberration, a real lens's dispersive glass; not
// through the pinhole).
bool banded(const RenderSettings& st) {
  const bool dispersive = st.real_lens && st.real_lens.lens->dispersive();
  return (st.lens.aperture.chromatic() || dispersive) && st.mode != Mode::Pinhole;
}

// A pixel's colour from the sum of its n samples: their mean, or with chromatic aberration each
// channel the mean of its band's samples (sample_band balances them; a band without a sample
// leaves the plain mean, which is unbiased too).
glm::vec3 finish_pixel(const RenderSettings& st, int x, int y, glm::dvec3 sum, std::uint32_t n) {
  if (n == 0) return glm::vec3(0.0f);
  glm::dvec3 mean = sum / static_cast<double>(n);
  if (banded(st)) {
    const std::uint64_t bands = band_key(st, x, y);
    const std::uint32_t counts[3] = {band_samples(bands, n, 0), band_samples(bands, n, 1),
                                     band_samples(bands, n, 2)};
    if (counts[0] && counts[1] && counts[2])
      for (int k = 0; k < 3; ++k) mean[k] = sum[k] / (3.0 * counts[k]);
  }
  return glm::vec3(mean);
}

// The radiance of samples [s0, end) of pixel (x, y), summed.
glm::dvec3 pixel_sum(const Context& c, int x, int y, std::uint32_t s0, std::uint32_t end,
                     TileWork& work, float* density, PixelMoments* moments,
                     double* feature_sums = nullptr) {
  const RenderSettings& st = c.settings;
  const std::uint64_t pixel = pixel_key(st.seed, x, y, Dimension::Light);
  const PixelSamples samples(st, x, y);
  // Whether a sample evaluates a rough lobe (Shader::shade): a stratified sequence over the
  // pixel's samples, so the lobe is evaluated on close to n p of n samples.
  const auto lobe_scramble = static_cast<std::uint32_t>(
      mix64(pixel_key(st.pattern_seed.value_or(st.seed), x, y, Dimension::Lobe)));
  const bool chromatic = banded(st);
  const std::uint64_t bands = band_key(st, x, y);
  glm::dvec3 acc(0.0);
  // The camera rays of a block of samples first (a real lens traces them together), then their
  // paths.
  int block_bands[PixelSamples::kBlock];
  LensSample block_rays[PixelSamples::kBlock];
  for (std::uint32_t first = s0; first < end; first += PixelSamples::kBlock) {
    const std::uint32_t n = std::min(PixelSamples::kBlock, end - first);
    // Chromatic aberration: the sample's band, whose channel alone it estimates (finish_pixel).
    for (std::uint32_t i = 0; i < n; ++i)
      block_bands[i] = chromatic ? sample_band(bands, first + i) : -1;
    samples.rays(c.camera, first, n, block_bands, block_rays);
    for (std::uint32_t i = 0; i < n; ++i) {
      const std::uint32_t s = first + i;
      const int band = block_bands[i];
      // Weight 0: stopped by the vignetting stop, a lens sample that brings no light.
      const LensSample& lens = block_rays[i];
      scene::Ray ray = clipped(c.camera, st, lens.ray);
      std::uint64_t key = hash_combine(pixel, s);
      ray.seed = static_cast<std::uint32_t>(key ^ (key >> 32));  // BLEND: one draw per sample
      Rng rng(key, s);
      SampleFeatures f;
      glm::vec3 l(0.0f);
      if (lens.weight > 0.0f)
        l = lens.weight *
            trace_camera_ray(c, ray, key, stratified_1d(s, lobe_scramble), rng, work, density,
                             feature_sums ? &f : nullptr);
      if (band >= 0) l = in_band(l, band);
      if (!(std::isfinite(l.x) && std::isfinite(l.y) && std::isfinite(l.z))) l = glm::vec3(0.0f);
      acc += glm::dvec3(l);
      if (moments) {
        const double v = scene::luminance(l);
        moments->sum += v, moments->sum2 += v * v, ++moments->count;
      }
      if (feature_sums) {
        double* fs = feature_sums;
        const glm::vec3 weighted = lens.weight * f.emission;
        const double v = scene::luminance(l - (band >= 0 ? in_band(weighted, band) : weighted));
        for (int k = 0; k < 3; ++k)
          fs[k] += f.albedo[k], fs[3 + k] += f.normal[k], fs[10 + k] += f.emission[k];
        if (f.hit) fs[6] += f.depth, fs[7] += 1.0;
        fs[8] += v, fs[9] += v * v;
        const double e = scene::luminance(f.emission), a = scene::luminance(f.albedo);
        fs[13] += e, fs[14] += e * e, fs[15] += a * a;
      }
    }
  }
  return acc;
}

// The extra lens samples of a pixel whose emission or albedo varies (RenderSettings::
// lens_features): rays that only look at what they hit need no shading, so lamps' bokeh, the
// sky's edges and the blur bands where a defocused object meets what is behind it can be
// integrated far beyond the colour's samples at little cost. At least kFeatureSamples, or as many
// as the pixel's own.
constexpr std::uint32_t kFeatureSamples = 32;
// The relative spread of a pixel's emission or albedo that calls for them (see render()).
constexpr double kFeatureSpread = 0.1;

// Samples [s0, end) of pixel (x, y) traced for what their first hits emit towards the camera
// (or the background) and their albedo, added into `sums` (kFeatureSums layout: 0-2 albedo,
// 10-12 emission, 13 its luminance, 14 that squared, 15 the albedo's luminance squared).
void add_feature_samples(const Context& c, int x, int y, std::uint32_t s0, std::uint32_t end,
                         RayCounters& counters, double* sums) {
  const RenderSettings& st = c.settings;
  const std::uint64_t pixel = pixel_key(st.seed, x, y, Dimension::Light);
  const PixelSamples samples(st, x, y);
  for (std::uint32_t s = s0; s < end; ++s) {
    const LensSample lens = samples.ray(c.camera, s);
    const bool blocked = lens.weight == 0.0f;  // the vignetting stop's
    scene::Ray ray = clipped(c.camera, st, lens.ray);
    const std::uint64_t key = hash_combine(pixel, s);
    ray.seed = static_cast<std::uint32_t>(key ^ (key >> 32));
    glm::vec3 e(0.0f), a(0.0f);
    const scene::Hit hit = blocked ? scene::Hit{} : c.accel.intersect(ray);
    if (!blocked) ++counters.rays;
    if (blocked) {
      // Stopped by the vignetting stop: no light and no surface.
    } else if (hit.valid()) {
      const ShadingPoint p = c.shader.prepare(ray, hit);
      e = c.shader.emitted(p);
      a = p.material.base_color;
    } else {
      e = c.shader.background(ray.direction);
    }
    if (!(std::isfinite(e.x) && std::isfinite(e.y) && std::isfinite(e.z))) e = glm::vec3(0.0f);
    const double l = scene::luminance(e), la = scene::luminance(a);
    for (int k = 0; k < 3; ++k) sums[k] += a[k], sums[10 + k] += e[k];
    sums[13] += l, sums[14] += l * l, sums[15] += la * la;
  }
}

// Samples [s0, s1) of every pixel of a tile (up to the pixel's own count), added into `sum`.
// Returns the number of samples taken.
std::uint64_t render_samples(const Context& c, const Tile& t, std::uint32_t s0, std::uint32_t s1,
                             std::vector<double>& sum, TileWork& work,
                             PixelCacheStats& pixel_stats) {
  const RenderSettings& st = c.settings;
  std::uint64_t taken = 0;
  for (int y = t.y0; y < t.y1; ++y)
    for (int x = t.x0; x < t.x1; ++x) {
      if (masked_out(st, x, y)) continue;
      const std::size_t index = static_cast<std::size_t>(y) * st.width + x;
      const std::uint32_t end = c.pixel_samples ? std::min(s1, c.pixel_samples[index]) : s1;
      if (end <= s0) continue;
      taken += end - s0;
      PixelMoments* moments = c.moments ? &c.moments[index] : nullptr;
      std::uint64_t lookups_before = work.lookups, hits_before = work.hits + work.tile_hits;
      float* density = pixel_stats.enabled() ? pixel_stats.created.pixel(x, y) : nullptr;
      const glm::dvec3 acc =
          pixel_sum(c, x, y, s0, end, work, density, moments,
                    c.feature_sums ? c.feature_sums + index * kFeatureSums : nullptr);
      if (pixel_stats.enabled()) {
        pixel_stats.hits.at(x, y, 0) += static_cast<float>(work.hits + work.tile_hits - hits_before);
        pixel_stats.lookups.at(x, y, 0) += static_cast<float>(work.lookups - lookups_before);
      }
      double* px = &sum[index * 3];
      px[0] += acc.x, px[1] += acc.y, px[2] += acc.z;
    }
  return taken;
}

// The unbiased sample variance over n, that of the mean, from a sum and a sum of squares.
float variance_of_mean(double sum, double sum2, double n) {
  const double mean = sum / n;
  return n > 1 ? static_cast<float>(std::max(0.0, sum2 - n * mean * mean) / ((n - 1) * n)) : 0.0f;
}

// Pixel i's emission and albedo estimates from its sums `s` (kFeatureSums layout) over m samples:
// the colour's own, and any extra ones add_feature_samples added.
void set_feature_estimates(LensFeatures& f, std::size_t i, const double* s, double m) {
  for (int k = 0; k < 3; ++k) {
    f.emission_estimate.data()[i * 3 + k] = static_cast<float>(s[10 + k] / m);
    f.albedo_estimate.data()[i * 3 + k] = static_cast<float>(s[k] / m);
  }
  f.emission_variance.data()[i] = variance_of_mean(s[13], s[14], m);
}

// The lens features' images from their per-pixel sums (kFeatureSums per pixel); `samples(i)`:
// the samples pixel i took. The estimates are those of these samples until refined.
template <class Samples>
LensFeatures lens_features_from(const std::vector<double>& sums, int w, int h, Samples samples) {
  LensFeatures f;
  f.albedo = image::Image(w, h, 3, 0.0f);
  f.normal = image::Image(w, h, 3, 0.0f);
  f.depth = image::Image(w, h, 1, std::numeric_limits<float>::infinity());
  f.coverage = image::Image(w, h, 1, 0.0f);
  f.variance = image::Image(w, h, 1, 0.0f);
  f.emission = image::Image(w, h, 3, 0.0f);
  f.emission_estimate = image::Image(w, h, 3, 0.0f);
  f.albedo_estimate = image::Image(w, h, 3, 0.0f);
  f.emission_variance = image::Image(w, h, 1, 0.0f);
  for (std::size_t i = 0; i < f.depth.pixel_count(); ++i) {
    const double* s = &sums[i * kFeatureSums];
    const double n = samples(i);
    if (!(n > 0)) continue;
    for (int k = 0; k < 3; ++k) {
      f.albedo.data()[i * 3 + k] = static_cast<float>(s[k] / n);
      f.normal.data()[i * 3 + k] = static_cast<float>(s[3 + k] / n);
      f.emission.data()[i * 3 + k] = static_cast<float>(s[10 + k] / n);
    }
    if (s[7] > 0) f.depth.data()[i] = static_cast<float>(s[6] / s[7]);
    f.coverage.data()[i] = static_cast<float>(s[7] / n);
    f.variance.data()[i] = variance_of_mean(s[8], s[9], n);
    set_feature_estimates(f, i, s, n);
  }
  return f;
}

}  // namespace

ShadingSettings cache_sample_shading(const ShadingSettings& per_ray, int sample_quality) {
  ShadingSettings q = per_ray;
  q.light_samples *= sample_quality;
  q.gather_rays *= sample_quality;
  return q;
}

namespace {
Context make_context(const scene::Scene& scene, const scene::Accel& accel,
                     const scene::Camera& camera, const RenderSettings& settings) {
  const ThinLensCamera cam = make_camera(camera, settings);
  return Context{scene,
                 accel,
                 settings,
                 cam,
                 Shader(scene, accel, settings.shading),
                 Shader(scene, accel,
                        cache_sample_shading(settings.shading, effective_sample_quality(settings))),
                 Shader(scene, accel, direct_shading(settings)),
                 frame_lookup(settings, cam)};
}
}  // namespace

ShadingSettings direct_shading(const RenderSettings& settings) {
  ShadingSettings d = settings.shading;
  d.light_samples = settings.cache.direct_light_samples;
  d.gather_rays = settings.cache.direct_gather_rays;
  return d;
}

int recommended_sample_quality(int spp, int gather_rays) {
  const long default_gather = ShadingSettings{}.gather_rays;
  const long scaled = std::max(static_cast<long>(std::max(spp, 0)) * default_gather /
                                   std::max(gather_rays, 1),
                               1L);
  return static_cast<int>(std::clamp((scaled + 8) / 16, 1L, 256L));
}

int effective_sample_quality(const RenderSettings& settings) {
  if (settings.cache.sample_quality != kAutoSampleQuality) return settings.cache.sample_quality;
  return recommended_sample_quality(settings.spp, settings.shading.gather_rays);
}

Mode parse_mode(const std::string& name) {
  if (name == "pinhole") return Mode::Pinhole;
  if (name == "drt") return Mode::Drt;
  if (name == "accumulation") return Mode::Accumulation;
  throw Error("unknown render mode '" + name + "' (valid: pinhole, drt, accumulation)");
}

const std::vector<std::string>& mode_names() {
  static const std::vector<std::string> names = {"pinhole", "drt", "accumulation"};
  return names;
}

const char* mode_name(Mode mode) {
  switch (mode) {
    case Mode::Pinhole: return "pinhole";
    case Mode::Drt: return "drt";
    case Mode::Accumulation: return "accumulation";
  }
  return "?";
}

void RenderSettings::validate() const {
  if (width < 1 || height < 1 || width > 16384 || height > 16384)
    throw Error("image size " + std::to_string(width) + "x" + std::to_string(height) +
                " is out of range (1 to 16384 per side)");
  if (spp < 1 || spp > (1 << 20))
    throw Error("samples per pixel must be in [1, 1048576], got " + std::to_string(spp));
  if (threads < 0 || threads > 4096) throw Error("thread count must be >= 0 (0: all cores)");
  if (!std::isfinite(near_depth) || near_depth < 0.0f)
    throw Error("near clipping depth must be a finite number >= 0");
  if (mask && (mask->width() != width || mask->height() != height || mask->channels() != 1))
    throw Error("render mask must be a 1-channel image of the render size");
  lens.validate();
  shading.validate();
  adaptive.validate();
  if (adaptive.enabled && mode != Mode::Drt)
    throw Error(std::string("adaptive lens sampling applies to drt renders, not ") +
                mode_name(mode));
  if (cache.cache) {
    cache.radius.validate();
    if (cache.sample_quality != kAutoSampleQuality &&
        (cache.sample_quality < 1 || cache.sample_quality > 256))
      throw Error("cache sample quality must be in [1, 256] (0: auto)");
    if (!(cache.sample_error > 0.0f) ||
        !(cache.max_sample_rounds >= 1 && cache.max_sample_rounds <= 64))
      throw Error("cache sample refinement: error must be positive, rounds in [1, 64]");
    try {
      cache_sample_shading(shading, effective_sample_quality(*this)).validate();
    } catch (const Error& e) {
      throw Error("cache samples (" + std::to_string(effective_sample_quality(*this)) +
                  " times the per-ray shading): " + e.what());
    }
    if (!(cache.direct_below >= 0.0f && cache.direct_below <= 1e6f))
      throw Error("cache: lens rays below which hits are shaded per ray must be in [0, 1e6]");
    if (!(cache.direct_cost_ratio >= 0.0f && cache.direct_cost_ratio <= 1e6f))
      throw Error("cache: the in-focus cost ratio must be in [0, 1e6]");
    try {
      direct_shading(*this).validate();
    } catch (const Error& e) {
      throw Error(std::string("per-ray shading of hits the cache skips: ") + e.what());
    }
    if (cache.lookup.min_samples < 1 || cache.lookup.min_samples > 1024)
      throw Error("cache: samples needed per lookup must be in [1, 1024]");
    if (!(cache.lookup.max_normal_angle_deg > 0.0f && cache.lookup.max_normal_angle_deg <= 90.0f))
      throw Error("cache: normal angle threshold must be in (0, 90] degrees");
    if (visibility_only || mode == Mode::Pinhole) {
      // Harmless, but nothing would be cached: say so rather than silently ignoring it.
      throw Error(std::string("the radiance cache applies to drt and accumulation renders, not ") +
                  (visibility_only ? "visibility-only" : "pinhole") + " renders");
    }
  }
}

cache::LookupOptions frame_lookup(const RenderSettings& settings, const ThinLensCamera& camera) {
  cache::LookupOptions o = settings.cache.lookup;
  const glm::dvec2 squeeze = settings.lens.aperture.footprint_squeeze();
  if (squeeze.x == 1.0 && squeeze.y == 1.0) return o;
  // The oval's smaller axis lies along the image's x where the bokeh is taller than wide.
  o.footprint_squeeze = static_cast<float>(std::min(squeeze.x, squeeze.y));
  o.footprint_axis = squeeze.x < squeeze.y ? camera.right() : camera.up();
  o.camera_position = camera.position();
  o.camera_forward = camera.forward();
  // min_factor pixel footprints (eq. (4.1)), which grow linearly with depth.
  o.floor_per_depth = static_cast<float>(settings.cache.radius.min_factor *
                                         camera.imaging().pixel_footprint(1.0));
  return o;
}

ThinLensCamera make_camera(const scene::Camera& camera, const RenderSettings& settings) {
  return ThinLensCamera(camera.camera_to_world, camera.yfov, settings.lens, settings.width,
                        settings.height, settings.real_lens);
}

RenderOutput render(const scene::Scene& scene, const scene::Accel& accel,
                    const scene::Camera& camera, const RenderSettings& settings) {
  settings.validate();
  auto start = std::chrono::steady_clock::now();
  cache::RadianceCache* cache = settings.cache.cache;
  Context c = make_context(scene, accel, camera, settings);
  const int w = settings.width, h = settings.height;
  RenderOutput out;
  out.color = image::Image(w, h, 3, 0.0f);
  out.depth = image::Image(w, h, 1, std::numeric_limits<float>::infinity());
  out.normal = image::Image(w, h, 3, 0.0f);
  out.ids = image::Image(w, h, 1, -1.0f);
  out.albedo = image::Image(w, h, 3, 0.0f);
  PixelCacheStats pixel_stats;
  if (cache) {
    pixel_stats.lookups = image::Image(w, h, 1, 0.0f);
    pixel_stats.hits = image::Image(w, h, 1, 0.0f);
    pixel_stats.created = image::Image(w, h, 1, 0.0f);
  }

  const std::vector<Tile> tiles = make_tiles(w, h);
  const int threads = resolve_threads(settings.threads);
  // Passes of sample ranges. Accumulation: one lens position per pass. With a cache: doubling
  // passes, so early passes fill the cache that later (larger) passes read. Otherwise: one pass.
  // Adaptive sampling (drt): the passes up to the pilot's count, the allocation, then the passes
  // on to the largest count a pixel got.
  using Passes = std::vector<std::pair<std::uint32_t, std::uint32_t>>;
  const bool accumulation = settings.mode == Mode::Accumulation;
  auto passes_between = [&](std::uint32_t begin, std::uint32_t end) {
    Passes passes;
    if (accumulation) {
      for (std::uint32_t s = begin; s < end; ++s) passes.emplace_back(s, s + 1);
    } else if (cache) {
      for (std::uint32_t s0 = begin, n = std::max(begin, 1u); s0 < end; s0 += n, n = s0)
        passes.emplace_back(s0, std::min(end, s0 + n));
    } else if (begin < end) {
      passes.emplace_back(begin, end);
    }
    return passes;
  };
  const auto spp = static_cast<std::uint32_t>(settings.spp);
  const bool shaded = !settings.visibility_only;
  const std::uint32_t pilot =
      shaded && settings.mode == Mode::Drt ? pilot_samples(settings.adaptive, settings.spp) : 0;
  std::vector<char> rendered(static_cast<size_t>(w) * h, 0);
  std::uint64_t rendered_count = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      rendered_count += rendered[static_cast<size_t>(y) * w + x] = !masked_out(settings, x, y);
  std::vector<PixelMoments> moments(pilot > 0 ? rendered.size() : 0);
  std::vector<std::uint32_t> pixel_samples;
  c.moments = pilot > 0 ? moments.data() : nullptr;

  std::vector<double> sum(static_cast<size_t>(w) * h * 3, 0.0);
  const bool features = settings.lens_features && !settings.visibility_only;
  std::vector<double> feature_sums(features ? rendered.size() * kFeatureSums : 0, 0.0);
  c.feature_sums = features ? feature_sums.data() : nullptr;
  std::vector<TileWork> work(tiles.size());
  if (settings.cache.cache && settings.cache.insert && settings.cache.direct_cost_ratio > 0.0f &&
      spp > kFocusCostSamples && !settings.visibility_only) {
    c.focus = FocusState::Measuring;
    const int middle = (h + kTileSize - 1) / kTileSize / 2;
    for (size_t i = 0; i < tiles.size(); ++i)
      work[i].samples_focus =
          (tiles[i].y0 / kTileSize) % kFocusSampleRows == middle % kFocusSampleRows;
  }
  RenderStats& st = out.stats;
  std::uint64_t rays = 0, shading_points = 0, camera_rays = 0;
  FocusCost focus;
  auto collect = [&](TileWork& tw) {  // after each parallel loop, in tile order
    rays += tw.rays.rays;
    shading_points += tw.rays.shading_points;
    st.cache_lookups += tw.lookups;
    st.cache_hits += tw.hits;
    st.cache_tile_hits += tw.tile_hits;
    st.cache_direct += tw.direct;
    st.cache_sample_rays += tw.sample_rays;
    focus += tw.focus;
    st.cache_lookup_seconds += tw.lookup_seconds;
    tw.rays = RayCounters{};
    tw.focus = FocusCost{};
    tw.lookups = tw.hits = tw.tile_hits = tw.direct = tw.sample_rays = 0;
    tw.lookup_seconds = 0.0;
  };
  const std::uint64_t total_work = shaded ? rendered_count * spp : rendered_count;
  Progress progress(settings.progress_label, total_work, settings.progress);

  tbb::task_arena arena(threads);
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, tiles.size(), 1), [&](const auto& r) {
      for (size_t i = r.begin(); i != r.end(); ++i) render_aovs(c, tiles[i], out, work[i].rays);
    });
  });
  for (TileWork& tw : work) collect(tw);
  if (!shaded) progress.advance(total_work);

  auto run_pass = [&](std::uint32_t s0, std::uint32_t s1) {
    std::vector<std::uint64_t> taken(tiles.size(), 0);
    arena.execute([&] {
      tbb::parallel_for(tbb::blocked_range<size_t>(0, tiles.size(), 1), [&](const auto& r) {
        for (size_t i = r.begin(); i != r.end(); ++i) {
          taken[i] = render_samples(c, tiles[i], s0, s1, sum, work[i], pixel_stats);
          progress.advance(taken[i]);
        }
      });
    });
    ++st.passes;
    for (size_t i = 0; i < tiles.size(); ++i) camera_rays += taken[i];
    for (TileWork& tw : work) collect(tw);
    if (!cache) return;
    // Merge the tiles' new samples in tile order; insert() sorts them canonically anyway.
    std::vector<cache::CacheSample> batch;
    std::vector<cache::TraceLookup> traced;
    for (TileWork& tw : work) {
      tw.buffer.append_to(&batch);
      tw.buffer.clear();
      if (settings.cache.trace) {
        traced.insert(traced.end(), tw.traced.begin(), tw.traced.end());
        tw.traced.clear();
      }
    }
    auto t0 = std::chrono::steady_clock::now();
    if (settings.cache.insert && !batch.empty()) cache->insert(batch);
    st.cache_insert_seconds += seconds_since(t0);
    st.cache_inserted += batch.size();
    if (settings.cache.trace) {
      settings.cache.trace->add_lookups(traced);
      settings.cache.trace->add_inserts(batch);
    }
    // CacheSettings::direct_cost_ratio: measured over the first lens samples, chosen once.
    if (c.focus == FocusState::Measuring && s1 >= kFocusCostSamples) {
      st.focus_cost_ratio = focus_cost_ratio(focus, s1, spp);
      st.focus_per_ray = st.focus_cost_ratio > settings.cache.direct_cost_ratio;
      c.focus = st.focus_per_ray ? FocusState::PerRay : FocusState::Cached;
    }
  };

  if (shaded) {
    std::uint32_t largest = spp;
    if (pilot > 0) {
      for (auto [s0, s1] : passes_between(0, pilot)) run_pass(s0, s1);
      pixel_samples =
          allocate_samples(moments, rendered, w, h, settings.spp, settings.adaptive, settings.seed);
      c.pixel_samples = pixel_samples.data();
      c.moments = nullptr;
      largest = *std::max_element(pixel_samples.begin(), pixel_samples.end());
    }
    for (auto [s0, s1] : passes_between(pilot, largest)) run_pass(s0, s1);
  }
  progress.finish();

  if (shaded) {
    std::vector<float>& color = out.color.data();
    for (size_t i = 0; i < rendered.size(); ++i) {
      const std::uint32_t n = pixel_samples.empty() ? spp : pixel_samples[i];
      const glm::vec3 v = finish_pixel(settings, static_cast<int>(i % w), static_cast<int>(i / w),
                                       {sum[i * 3], sum[i * 3 + 1], sum[i * 3 + 2]}, n);
      for (int k = 0; k < 3; ++k) color[i * 3 + k] = v[k];
    }
    if (features) {
      auto samples_of = [&](std::size_t i) {
        return !rendered[i] ? 0u : pixel_samples.empty() ? spp : pixel_samples[i];
      };
      // Extra feature samples where the emission or the albedo varies: over a pixel's own
      // samples, or between it and a neighbour (a pixel at a blur band's edge whose few samples
      // all met one surface; with one sample per pixel, the only sign).
      auto mean_of = [&](std::size_t i, int k) {
        return feature_sums[i * kFeatureSums + k] / std::max(1u, samples_of(i));
      };
      auto albedo_luminance = [&](std::size_t i) {
        const double* fs = &feature_sums[i * kFeatureSums];
        return scene::luminance(glm::vec3(fs[0], fs[1], fs[2])) / std::max(1u, samples_of(i));
      };
      // A spread that matters: a standard deviation over the samples above kFeatureSpread of
      // the mean (a texture's gentle variation does not; two surfaces in one pixel do).
      auto spread = [](double sum2, double n, double mean) {
        return n > 1 && sum2 / n - mean * mean >
                            kFeatureSpread * kFeatureSpread * std::max(mean * mean, 1e-6);
      };
      auto differs = [](double a, double b) {
        return std::abs(a - b) > kFeatureSpread * std::max({std::abs(a), std::abs(b), 1e-3});
      };
      auto varies = [&](int x, int y) {
        const std::size_t i = static_cast<std::size_t>(y) * w + x;
        const double* fs = &feature_sums[i * kFeatureSums];
        const double n = samples_of(i), e = mean_of(i, 13), a = albedo_luminance(i);
        if (spread(fs[14], n, e) || spread(fs[15], n, a)) return true;
        for (int qy = std::max(0, y - 1); qy <= std::min(h - 1, y + 1); ++qy)
          for (int qx = std::max(0, x - 1); qx <= std::min(w - 1, x + 1); ++qx) {
            const std::size_t j = static_cast<std::size_t>(qy) * w + qx;
            if (differs(mean_of(j, 13), e) || differs(albedo_luminance(j), a)) return true;
          }
        return false;
      };
      out.lens_features = lens_features_from(feature_sums, w, h, samples_of);
      std::vector<RayCounters> feature_rays(tiles.size());
      arena.execute([&] {
        tbb::parallel_for(tbb::blocked_range<size_t>(0, tiles.size(), 1), [&](const auto& r) {
          for (size_t t = r.begin(); t != r.end(); ++t)
            for (int y = tiles[t].y0; y < tiles[t].y1; ++y)
              for (int x = tiles[t].x0; x < tiles[t].x1; ++x) {
                const std::size_t i = static_cast<std::size_t>(y) * w + x;
                const std::uint32_t n = samples_of(i);
                if (n == 0 || !varies(x, y)) continue;
                // The pixel's sums, continued: `varies` reads its neighbours' as they were.
                double sums[kFeatureSums];
                std::copy_n(&feature_sums[i * kFeatureSums], kFeatureSums, sums);
                const std::uint32_t extra = std::max(kFeatureSamples, n);
                add_feature_samples(c, x, y, n, n + extra, feature_rays[t], sums);
                set_feature_estimates(out.lens_features, i, sums, double(n) + extra);
              }
        });
      });
      for (const RayCounters& rc : feature_rays) rays += rc.rays;
    }
    if (!pixel_samples.empty()) {
      out.samples = image::Image(w, h, 1, 0.0f);
      for (size_t i = 0; i < rendered.size(); ++i)
        out.samples.data()[i] = static_cast<float>(pixel_samples[i]);
    }
  }
  if (cache) {
    out.cache_hits = image::Image(w, h, 1, 0.0f);
    for (size_t i = 0; i < out.cache_hits.pixel_count(); ++i) {
      float n = pixel_stats.lookups.data()[i];
      out.cache_hits.data()[i] = n > 0.0f ? pixel_stats.hits.data()[i] / n : 0.0f;
    }
    out.cache_density = std::move(pixel_stats.created);
    st.cache_samples = cache->size();
    st.cache_memory_bytes = cache->memory_bytes();
  }
  st.seconds = seconds_since(start);
  st.camera_rays = camera_rays;
  st.rays = rays;
  st.shading_points = shading_points;
  st.threads = threads;
  return out;
}

std::vector<PixelRender> render_pixels(const scene::Scene& scene, const scene::Accel& accel,
                                       const scene::Camera& camera,
                                       const RenderSettings& settings,
                                       const std::vector<std::uint32_t>& pixels) {
  settings.validate();
  if (settings.cache.cache || settings.adaptive.enabled || settings.visibility_only)
    throw Error("render_pixels: no radiance cache, adaptive sampling or visibility-only render");
  check_pixel_indices(settings, pixels, "render_pixels");
  Context c = make_context(scene, accel, camera, settings);
  std::vector<PixelRender> out(pixels.size());
  const auto w = static_cast<std::uint32_t>(settings.width);
  const auto spp = static_cast<std::uint32_t>(settings.spp);
  const int threads = resolve_threads(settings.threads);
  tbb::task_arena arena(threads);
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, pixels.size(), 16), [&](const auto& r) {
      TileWork work;
      for (size_t i = r.begin(); i != r.end(); ++i) {
        const int x = static_cast<int>(pixels[i] % w), y = static_cast<int>(pixels[i] / w);
        const CentreHit h = trace_centre(scene, accel, c.camera, settings, x, y, work.rays);
        // As render() divides its sums: one pass, so the sum is this pixel's.
        const glm::dvec3 sum = pixel_sum(c, x, y, 0, spp, work, nullptr, nullptr);
        PixelRender& px = out[i];
        px.color = finish_pixel(settings, x, y, sum, spp);
        px.depth = h.hit ? h.depth : std::numeric_limits<float>::infinity();
        px.id = h.id;
      }
    });
  });
  return out;
}

std::vector<PixelVisibility> trace_pixel_centres(const scene::Scene& scene,
                                                 const scene::Accel& accel,
                                                 const scene::Camera& camera,
                                                 const RenderSettings& settings,
                                                 const std::vector<std::uint32_t>& pixels) {
  settings.validate();
  const ThinLensCamera cam = make_camera(camera, settings);
  const std::uint32_t w = static_cast<std::uint32_t>(settings.width);
  check_pixel_indices(settings, pixels, "trace_pixel_centres");
  std::vector<PixelVisibility> out(pixels.size());
  const int threads = resolve_threads(settings.threads);
  tbb::task_arena arena(threads);
  arena.execute([&] {
    // Chunks of a few hundred pixels: a ray costs about a microsecond.
    tbb::parallel_for(tbb::blocked_range<size_t>(0, pixels.size(), 256), [&](const auto& r) {
      RayCounters counters;
      for (size_t i = r.begin(); i != r.end(); ++i) {
        const int x = static_cast<int>(pixels[i] % w), y = static_cast<int>(pixels[i] / w);
        const CentreHit h = trace_centre(scene, accel, cam, settings, x, y, counters);
        out[i] = h.hit ? PixelVisibility{h.depth, h.id}
                       : PixelVisibility{std::numeric_limits<float>::infinity(), -1.0f};
      }
    });
  });
  return out;
}

}  // namespace dofcache::render
