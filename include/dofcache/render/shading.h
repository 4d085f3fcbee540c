#pragma once
// Physically based shading of glTF metallic-roughness surfaces, expensive in the way the paper's
// photon-mapped shading is, so that caching it pays:
//   L_o = L_e + (1 - F(n.v)) c_diff * E/pi + specular(v)
// E/pi, the diffuse illumination with the albedo factored out, is view independent: direct light
// from emissive triangles (soft shadows, several samples) and punctual lights, plus a final gather
// of cosine-weighted rays that evaluate direct light where they land. It is what the radiance cache
// stores. The GGX specular lobe is view dependent and is traced per ray, never cached.
#include <cstdint>
#include <vector>

#include <glm/vec3.hpp>

#include "dofcache/core/rng.h"
#include "dofcache/render/light_sampler.h"
#include "dofcache/scene/accel.h"
#include "dofcache/scene/scene.h"

namespace dofcache::render {

struct ShadingSettings {
  int light_samples = 4;   // shadow rays to area lights per shading point
  int gather_rays = 32;    // final-gather rays for diffuse indirect light
  int bounces = 1;         // diffuse indirect bounces (1: the gather sees direct light only)
  int specular_depth = 3;  // maximum chain of glossy/mirror reflections

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
};

// Read-only access to cached diffuse illumination, for surfaces seen in reflections (view
// independent there too). Must be deterministic and thread-safe.
class DiffuseLookup {
 public:
  virtual ~DiffuseLookup() = default;
  virtual bool lookup(const ShadingPoint& p, glm::vec3* e_over_pi) const = 0;
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

  // Outgoing radiance towards p.wo given the diffuse illumination at p (computed or cached).
  // `cached` (optional) serves the diffuse illumination of surfaces seen in reflections.
  glm::vec3 shade(const ShadingPoint& p, glm::vec3 diffuse_illumination, Rng& rng,
                  RayCounters& counters, const DiffuseLookup* cached = nullptr,
                  int depth = 0) const;

  // The diffuse-lobe multiplier (1 - F(n.v)) c_diff that turns E/pi into outgoing radiance.
  static glm::vec3 diffuse_reflectance(const ShadingPoint& p);
  static bool has_diffuse(const ShadingPoint& p);
  glm::vec3 emitted(const ShadingPoint& p) const;

  const ShadingSettings& settings() const { return settings_; }
  const scene::Scene& scene() const { return scene_; }
  const scene::Accel& accel() const { return accel_; }

 private:
  glm::vec3 direct_light(const ShadingPoint& p, int samples, std::uint64_t key, Rng& rng,
                         RayCounters& counters) const;
  glm::vec3 indirect_light(const ShadingPoint& p, int rays, int bounces_left, std::uint64_t key,
                           Rng& rng, RayCounters& counters,
                           float* harmonic_distance = nullptr) const;
  glm::vec3 specular(const ShadingPoint& p, Rng& rng, RayCounters& counters,
                     const DiffuseLookup* cached, int depth) const;
  bool visible(glm::vec3 from, glm::vec3 normal, glm::vec3 to_dir, float distance,
               RayCounters& counters) const;
  // Unit direction from x towards a punctual light and its distance (false if x is on it).
  bool direction_to(const scene::PunctualLight& light, glm::vec3 x, glm::vec3* wi,
                    float* distance) const;
  // Solid-angle density with which light sampling at `p` picks direction `wi` reaching emitter
  // triangle `triangle` at distance `distance` (for multiple importance sampling).
  float emitter_pdf(const ShadingPoint& p, std::uint32_t triangle, glm::vec3 wi,
                    float distance) const;

  std::vector<int> triangle_emitter_;  // emitter index of each triangle, -1 if it emits nothing

  const scene::Scene& scene_;
  const scene::Accel& accel_;
  ShadingSettings settings_;
  LightSampler light_sampler_;
  float epsilon_;  // ray offset, relative to the scene size
};

}  // namespace dofcache::render
