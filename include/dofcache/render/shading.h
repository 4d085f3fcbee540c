#pragma once
// Physically based shading of glTF metallic-roughness surfaces:
//   L_o = L_e + (1 - F(n.v)) c_diff * E/pi + specular(v)
// E/pi, the diffuse illumination with the albedo factored out, is view independent: it is what the
// radiance cache stores. The GGX specular lobe is view dependent and is traced per ray.
//
// Light transport is a path tracer in the pbrt / Cycles sense, with bounded variance:
// * next-event estimation at every vertex, triangle lights sampled by solid angle where that is
//   well conditioned (render/triangle_sampling.h), so points next to a light see no 1/d^2 spikes;
// * every emitter a BSDF-sampled ray meets (gather rays, reflection rays, path continuations) is
//   weighted against light sampling by the power heuristic (Veach 1997), and every light sample
//   against the BSDF strategy, counting each strategy's sample count;
// * `bounces` is the number of indirect bounces, diffuse or glossy, as Cycles' max bounces:
//   0 is direct light only; Russian roulette from the third vertex on.
// E/pi at a camera hit uses `light_samples` light samples and `gather_rays` cosine-weighted rays
// (a final gather); deeper vertices take one light sample and one continuation.
//
// An environment (render/environment.h) is one more light: a light sample goes to it with
// probability 1/2 when the scene also has emissive triangles (pbrt-v4's BVHLightSampler gives its
// infinite lights the same share), else always; rays that leave the scene meet it and are
// weighted against its light samples like rays that meet an emitter.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "dofcache/core/rng.h"
#include "dofcache/render/environment.h"
#include "dofcache/render/light_sampler.h"
#include "dofcache/render/triangle_sampling.h"
#include "dofcache/scene/accel.h"
#include "dofcache/scene/scene.h"

namespace dofcache::render {

struct GgxLobe;  // the specular lobe at one point (shading.cpp)

// What every material is rendered as. Lambert: a pure Lambertian reflector of albedo = the base
// colour (with its texture); metallic, the specular lobe and the (1 - F) weight of the diffuse
// lobe are ignored, emission, normal textures and alpha kept. The physics Blender Cycles' Diffuse
// BSDF gives, for the peer benchmark's same-physics check (docs/peer.md).
enum class MaterialOverride { None, Lambert };
const char* material_override_name(MaterialOverride o);  // "none", "lambert"
MaterialOverride parse_material_override(const std::string& name);  // throws dofcache::Error
const std::vector<std::string>& material_override_names();

struct ShadingSettings {
  int light_samples = 4;   // shadow rays to area lights per shading point
  int gather_rays = 32;    // final-gather rays for diffuse indirect light
  int bounces = 1;         // indirect bounces, diffuse or glossy (Cycles' max bounces; 0: direct)
  int specular_depth = 3;  // maximum chain of glossy/mirror reflections (0: no specular lobe)
  // At a camera hit, a rough dielectric lobe is evaluated with probability rate x its share of
  // the outgoing radiance (clamped to [1/16, 1]); 0 evaluates it on every ray.
  float rough_lobe_rate = 4.0f;
  MaterialOverride material_override = MaterialOverride::None;
  // Light from infinitely far away (null: none); shared, immutable.
  std::shared_ptr<const Environment> environment;

  void validate() const;   // throws dofcache::Error on absurd values
};

// Per-thread ray counters (summed by the renderer).
struct RayCounters {
  std::uint64_t rays = 0;            // every ray cast: camera, shadow, gather, reflection
  std::uint64_t shading_points = 0;  // full diffuse-illumination evaluations (cache misses)
};

// A hit prepared for shading: normals face the side the ray came from.
struct ShadingPoint {
  scene::SurfacePoint surface;
  scene::MaterialPoint material;
  glm::vec3 n{0.0f};   // shading normal, on the incoming side
  glm::vec3 ng{0.0f};  // geometric normal, on the incoming side
  glm::vec3 wo{0.0f};  // unit direction towards the viewer
  bool front_face = true;
  bool lambert = false;  // MaterialOverride::Lambert: no specular lobe, no Fresnel weight
};

class Shader {
 public:
  Shader(const scene::Scene& scene, const scene::Accel& accel, const ShadingSettings& settings);

  ShadingPoint prepare(const scene::Ray& ray, const scene::Hit& hit) const;

  // E/pi at `p` (RGB, albedo excluded). `key` seeds its stratified light and gather patterns.
  // If `harmonic_distance` is set it receives the harmonic mean length of the gather rays (Ward's
  // split-sphere bound on how fast the illumination can change; +inf if every ray escaped).
  glm::vec3 diffuse_illumination(const ShadingPoint& p, std::uint64_t key, Rng& rng,
                                 RayCounters& counters, float* harmonic_distance = nullptr) const;

  // E/pi for a cache sample, which many lens rays reuse: diffuse_illumination's two estimators
  // (light samples and gather rays, each MIS-weighted for the per-round counts) in rounds, each
  // an independent estimate from further points of the same stratified sequences. While the
  // standard error of the sum exceeds `relative_error` times the estimate, the rounds of the
  // estimator that removes the most variance per ray are doubled, each up to `max_rounds`.
  // A sample whose few gather rays met a small bright patch (the ceiling just above a lamp), or
  // whose few light samples fell on a skylight's mullions or a leaf's shadow, would otherwise
  // carry that outlier over its whole circle of confusion. (Stopping on the data biases the mean
  // slightly; the cache is an interpolation anyway.)
  glm::vec3 refined_diffuse_illumination(const ShadingPoint& p, std::uint64_t key, Rng& rng,
                                         RayCounters& counters, float* harmonic_distance,
                                         float relative_error, int max_rounds) const;

  // Outgoing radiance towards p.wo at a camera hit given its diffuse illumination (computed or
  // cached). `lobe_u`, uniform in [0, 1), decides whether a rough lobe is evaluated on this ray
  // (rough_lobe_probability); the renderer draws it from a pixel's stratified 1-D pattern, so
  // that a pixel's n samples evaluate the lobe close to n p times rather than a binomial number.
  glm::vec3 shade(const ShadingPoint& p, glm::vec3 diffuse_illumination, float lobe_u, Rng& rng,
                  RayCounters& counters) const;

  // The diffuse-lobe multiplier (1 - F(n.v)) c_diff that turns E/pi into outgoing radiance.
  static glm::vec3 diffuse_reflectance(const ShadingPoint& p);
  static bool has_diffuse(const ShadingPoint& p);
  glm::vec3 emitted(const ShadingPoint& p) const;
  // What a camera ray that leaves the scene along `direction` sees: the environment if it is
  // visible, else black.
  glm::vec3 background(glm::vec3 direction) const;

  const ShadingSettings& settings() const { return settings_; }
  const LightSampler& light_sampler() const { return light_sampler_; }
  const scene::Scene& scene() const { return scene_; }
  const scene::Accel& accel() const { return accel_; }

 private:
  struct LightSample {  // a direction towards an emissive triangle or the environment
    glm::vec3 wi{0.0f};
    float distance = 0.0f;
    float pdf = 0.0f;  // solid angle, the choice of emitter included
    glm::vec3 radiance{0.0f};
  };
  // Where a path is: bounces taken to reach the vertex, bounces still allowed, and the length of
  // the chain of specular reflections that reached it.
  struct PathDepth {
    int taken = 0;
    int left = 0;
    int glossy = 0;
  };

  // Running sums of the luminance of an estimator's samples (light samples or gather rays), for
  // the standard error of their mean.
  struct SampleMoments {
    double sum = 0.0, sum2 = 0.0;
    int count = 0;
    void add(double y) { sum += y, sum2 += y * y; }
    double variance_of_mean() const;  // 0 below two samples
  };
  // E/pi at p from `light_samples` light samples and `gather_rays` cosine-weighted rays, combined
  // by multiple importance sampling; `key` seeds their stratified patterns.
  glm::vec3 diffuse_estimate(const ShadingPoint& p, int light_samples, int gather_rays,
                             PathDepth depth, std::uint64_t key, Rng& rng, RayCounters& counters,
                             float* harmonic_distance) const;
  // The light samples' share of E/pi: `light_samples` of them (round r takes the r-th run of
  // points), MIS-weighted as n_light against n_gather rays.
  glm::vec3 light_estimate(const ShadingPoint& p, int light_samples, float n_light,
                           float n_gather, std::uint64_t key, Rng& rng, RayCounters& counters,
                           std::uint32_t round, SampleMoments* moments) const;
  // A visible light sample's MIS-weighted share of E/pi (n_light of them against n_gather rays).
  glm::vec3 diffuse_light(const ShadingPoint& p, const LightSample& ls, float n_light,
                          float n_gather) const;
  // The cosine-weighted rays' share of E/pi, against n_light light samples.
  glm::vec3 gather(const ShadingPoint& p, int rays, float n_light, PathDepth depth,
                   std::uint64_t key, Rng& rng, RayCounters& counters, float* harmonic_distance,
                   std::uint32_t first_index, SampleMoments* moments) const;
  // Radiance leaving a path vertex q towards q.wo, emission excluded (the caller weights it).
  glm::vec3 reflected(const ShadingPoint& q, PathDepth depth, Rng& rng,
                      RayCounters& counters) const;
  // The GGX lobe at p (keep 0 where it is off) and its estimators: punctual lights, a visible
  // light sample (MIS-weighted against the lobe's ray), and the ray itself.
  GgxLobe specular_lobe(const ShadingPoint& p, PathDepth depth) const;
  // How likely a camera hit evaluates its specular lobe (1 unless the lobe is rough), given the
  // luminance of the point's diffuse reflectance (1 - F) c.
  float rough_lobe_probability(const GgxLobe& lobe, float diffuse_luminance) const;
  // The lobe at a camera hit: punctual lights, a light sample of its own and the lobe's ray.
  glm::vec3 specular_at_camera_hit(const ShadingPoint& p, const GgxLobe& lobe, PathDepth depth,
                                   Rng& rng, RayCounters& counters) const;
  glm::vec3 specular_punctual(const ShadingPoint& p, const GgxLobe& lobe,
                              RayCounters& counters) const;
  glm::vec3 specular_light(const ShadingPoint& p, const GgxLobe& lobe,
                           const LightSample& ls) const;
  glm::vec3 specular_ray(const ShadingPoint& p, const GgxLobe& lobe, PathDepth depth, Rng& rng,
                         RayCounters& counters) const;
  // Light leaving a BSDF-sampled hit towards p: its emission weighted against `light_samples`
  // light samples at p (bsdf_density is the ray strategy's density times its sample count), the
  // rest by reflected() if bounces are left.
  // `survival`: the step's throughput, the Russian-roulette probability from the third vertex on.
  glm::vec3 continuation(const ShadingPoint& p, const scene::Ray& ray, const scene::Hit& hit,
                         float bsdf_density, float light_samples, PathDepth next, float survival,
                         Rng& rng, RayCounters& counters) const;
  // Radiance of the environment along a ray that left the scene, weighted against
  // `light_samples` light samples at its origin (bsdf_density as in continuation()).
  glm::vec3 escaped(glm::vec3 direction, float bsdf_density, float light_samples) const;
  // Whether light samples can be drawn (emissive triangles or an environment).
  bool has_sampled_lights() const { return !scene_.emitters.empty() || environment_ != nullptr; }
  // Punctual lights' E/pi at p (one shadow ray each; they cannot be hit, so no MIS).
  glm::vec3 punctual_diffuse(const ShadingPoint& p, RayCounters& counters) const;
  bool sample_light(const ShadingPoint& p, float u_pick, glm::vec2 u, LightSample* s) const;
  Triangle triangle(std::uint32_t index) const;
  // Solid-angle density with which sample_light at `p` picks direction `wi` reaching emitter
  // triangle `triangle` at distance `distance`.
  float light_pdf(const ShadingPoint& p, std::uint32_t triangle, glm::vec3 wi,
                  float distance) const;
  // Solid-angle density with which sample_light picks the environment in direction `wi`.
  float environment_pdf(glm::vec3 wi) const;
  // A ray leaving p along `direction` (p's own surface excluded).
  scene::Ray spawn(const ShadingPoint& p, glm::vec3 direction) const;
  bool visible(glm::vec3 from, glm::vec3 normal, glm::vec3 to_dir, float distance,
               RayCounters& counters) const;
  // Unit direction from x towards a punctual light and its distance (false if x is on it).
  bool direction_to(const scene::PunctualLight& light, glm::vec3 x, glm::vec3* wi,
                    float* distance) const;

  std::vector<int> triangle_emitter_;  // emitter index of each triangle, -1 if it emits nothing

  const scene::Scene& scene_;
  const scene::Accel& accel_;
  ShadingSettings settings_;
  LightSampler light_sampler_;
  float epsilon_;  // ray offset, relative to the scene size
  const Environment* environment_ = nullptr;  // settings_.environment
  float environment_pick_ = 0.0f;  // probability that a light sample goes to the environment
};

}  // namespace dofcache::render
