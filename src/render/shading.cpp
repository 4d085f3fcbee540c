#include "dofcache/render/shading.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include "dofcache/core/error.h"
#include "dofcache/lens/thin_lens.h"
#include "dofcache/render/ggx.h"
#include "dofcache/render/sampler.h"
#include "dofcache/render/triangle_sampling.h"

namespace dofcache::render {
namespace {

constexpr float kPi = 3.14159265358979f;
constexpr float kInvPi = 1.0f / kPi;
constexpr float kRoughLobeAlpha = 0.5f;  // GGX alpha (roughness ~0.71) from which a lobe is rough
constexpr float kMinRoughLobeProbability = 1.0f / 16.0f;

struct Frame {  // orthonormal basis around a unit normal (Duff et al. 2017)
  glm::vec3 t, b, n;
  explicit Frame(glm::vec3 normal) : n(normal) {
    float sign = std::copysign(1.0f, n.z);
    float a = -1.0f / (sign + n.z);
    float bb = n.x * n.y * a;
    t = {1.0f + sign * n.x * n.x * a, sign * bb, -sign * n.x};
    b = {bb, sign + n.y * n.y * a, -n.y};
  }
  glm::vec3 to_world(glm::vec3 v) const { return v.x * t + v.y * b + v.z * n; }
};

glm::vec3 cosine_hemisphere(glm::vec2 u) {
  glm::vec2 d = lens::concentric_disk(u);
  return {d.x, d.y, std::sqrt(std::max(0.0f, 1.0f - d.x * d.x - d.y * d.y))};
}

glm::vec3 fresnel_schlick(glm::vec3 f0, float cos_theta) {
  float m = 1.0f - std::clamp(cos_theta, 0.0f, 1.0f);
  float m5 = m * m * m * m * m;
  return f0 + (1.0f - f0) * m5;
}

glm::vec3 specular_f0(const scene::MaterialPoint& m) {
  return glm::mix(glm::vec3(0.04f), m.base_color, m.metallic);
}

float ggx_alpha(float roughness) { return std::max(roughness * roughness, 1e-4f); }

using scene::luminance;

// KHR_lights_punctual attenuation: inverse square, windowed by `range`, spot cone falloff.
float punctual_attenuation(const scene::PunctualLight& light, glm::vec3 to_light, float distance) {
  if (light.type == scene::PunctualLight::Type::Directional) return 1.0f;
  float att = 1.0f / std::max(distance * distance, 1e-8f);
  if (light.range > 0.0f) {
    float r = distance / light.range;
    float w = std::clamp(1.0f - r * r * r * r, 0.0f, 1.0f);
    att *= w * w;
  }
  if (light.type == scene::PunctualLight::Type::Spot) {
    float cos_outer = std::cos(light.outer_cone), cos_inner = std::cos(light.inner_cone);
    float scale = 1.0f / std::max(0.001f, cos_inner - cos_outer);
    float cd = glm::dot(light.direction, -to_light);
    float s = std::clamp((cd - cos_outer) * scale, 0.0f, 1.0f);
    att *= s * s;
  }
  return att;
}

// The power heuristic (Veach 1997, beta = 2) for a sample of the strategy with density `a` against
// one with density `b`, each density already multiplied by its strategy's sample count.
float power_heuristic(float a, float b) {
  if (!(a > 0.0f)) return 0.0f;
  if (!std::isfinite(a)) return 1.0f;
  const float ratio = b / a;
  return 1.0f / (1.0f + ratio * ratio);
}

float max_component(glm::vec3 v) { return std::max(v.x, std::max(v.y, v.z)); }

// A 64-bit pattern key drawn from a path's random stream, for vertices past the camera hit.
std::uint64_t draw_key(Rng& rng) {
  return (static_cast<std::uint64_t>(rng.next_u32()) << 32) | rng.next_u32();
}

}  // namespace

// The GGX lobe of one shading point: F0, roughness, and how likely its ray is traced.
struct GgxLobe {
  float alpha = 1.0f, n_v = 0.0f, keep = 0.0f;  // keep 0: no lobe here
  float fresnel = 0.0f;  // luminance of F(n.v): how much the lobe reflects towards the viewer
  glm::vec3 f0{0.0f};
  // f_s(wi) (n.wi) and the density of sampling wi by the lobe's ray, for a light direction.
  glm::vec3 eval(const glm::vec3& n, const glm::vec3& wo, const glm::vec3& wi, float* pdf) const {
    const float n_l = glm::dot(n, wi);
    *pdf = 0.0f;
    if (n_l <= 0.0f) return glm::vec3(0.0f);
    const glm::vec3 h = glm::normalize(wi + wo);
    const float n_h = std::max(glm::dot(n, h), 1e-6f), v_h = std::max(glm::dot(wo, h), 1e-6f);
    *pdf = ggx_vndf_pdf(n_h, n_v, alpha);
    return fresnel_schlick(f0, v_h) *
           (ggx_d(n_h, alpha) * smith_g1(n_v, alpha) * smith_g1(n_l, alpha) / (4.0f * n_v));
  }
};

const char* material_override_name(MaterialOverride o) {
  return o == MaterialOverride::Lambert ? "lambert" : "none";
}

MaterialOverride parse_material_override(const std::string& name) {
  if (name == "none") return MaterialOverride::None;
  if (name == "lambert") return MaterialOverride::Lambert;
  throw Error("unknown material override '" + name + "' (expected none or lambert)");
}

const std::vector<std::string>& material_override_names() {
  static const std::vector<std::string> names = {"none", "lambert"};
  return names;
}

void ShadingSettings::validate() const {
  auto check = [](int v, int lo, int hi, const char* name) {
    if (v < lo || v > hi)
      throw Error(std::string("shading: ") + name + " must be in [" + std::to_string(lo) + ", " +
                  std::to_string(hi) + "], got " + std::to_string(v));
  };
  check(light_samples, 0, 4096, "light samples");
  check(gather_rays, 0, 65536, "gather rays");
  check(bounces, 0, 16, "bounces");
  check(specular_depth, 0, 16, "specular depth");
  if (!(rough_lobe_rate >= 0.0f && rough_lobe_rate <= 1e3f))
    throw Error("shading: rough lobe rate must be in [0, 1000]");
}

Shader::Shader(const scene::Scene& scene, const scene::Accel& accel,
               const ShadingSettings& settings)
    : scene_(scene), accel_(accel), settings_(settings), light_sampler_(scene) {
  float extent = std::max(glm::length(scene.bounds.lower), glm::length(scene.bounds.upper));
  epsilon_ = 1e-4f * std::max(1.0f, extent);
  triangle_emitter_.assign(scene.mesh.triangles.size(), -1);
  for (std::size_t e = 0; e < scene.emitters.size(); ++e)
    triangle_emitter_[scene.emitters[e].triangle] = static_cast<int>(e);
  if (settings_.environment && !settings_.environment->is_black()) {
    environment_ = settings_.environment.get();
    environment_pick_ = scene.emitters.empty() ? 1.0f : 0.5f;
  }
}

bool Shader::direction_to(const scene::PunctualLight& light, glm::vec3 x, glm::vec3* wi,
                          float* distance) const {
  if (light.type == scene::PunctualLight::Type::Directional) {
    *wi = -light.direction;
    *distance = 2.0f * scene_.bounds.diagonal() + 1.0f;  // beyond everything
    return true;
  }
  glm::vec3 d = light.position - x;
  *distance = glm::length(d);
  if (*distance <= 0.0f) return false;
  *wi = d / *distance;
  return true;
}

Triangle Shader::triangle(std::uint32_t index) const {
  const glm::uvec3 tri = scene_.mesh.triangles[index];
  const auto& P = scene_.mesh.positions;
  return {P[tri.x], P[tri.y], P[tri.z]};
}

bool Shader::sample_light(const ShadingPoint& p, float u_pick, glm::vec2 u,
                          LightSample* s) const {
  if (environment_) {
    if (u_pick < environment_pick_) {
      float pdf;
      if (!environment_->sample(u, &s->wi, &pdf, &s->radiance)) return false;
      s->distance = 2.0f * scene_.bounds.diagonal() + 1.0f;  // beyond everything
      s->pdf = environment_pick_ * pdf;
      return s->pdf > 0.0f && std::isfinite(s->pdf);
    }
    // The rest of u_pick chooses among the emitters.
    u_pick = std::min((u_pick - environment_pick_) / (1.0f - environment_pick_), 0x1.fffffep-1f);
  }
  std::size_t e;
  float pick;
  if (!light_sampler_.sample(p.surface.position, p.n, u_pick, &e, &pick)) return false;
  if (environment_) pick *= 1.0f - environment_pick_;
  const scene::Emitter& em = scene_.emitters[e];
  const Triangle t = triangle(em.triangle);
  TriangleSample ts;
  if (!sample_triangle(p.surface.position, t, u, &ts)) return false;
  // A one-sided emitter lights only the side its winding faces.
  if (!scene_.materials[scene_.mesh.triangle_material[em.triangle]].double_sided &&
      glm::dot(glm::cross(t.b - t.a, t.c - t.a), ts.wi) >= 0.0f)
    return false;
  s->wi = ts.wi;
  s->distance = ts.distance;
  s->pdf = pick * ts.pdf;
  s->radiance = em.radiance;
  return s->pdf > 0.0f && std::isfinite(s->pdf);
}

float Shader::light_pdf(const ShadingPoint& p, std::uint32_t triangle_index, glm::vec3 wi,
                        float distance) const {
  const int e = triangle_emitter_[triangle_index];
  if (e < 0) return 0.0f;
  const float pick =
      light_sampler_.probability(p.surface.position, p.n, static_cast<std::size_t>(e));
  if (!(pick > 0.0f)) return 0.0f;
  const float env_share = environment_ ? 1.0f - environment_pick_ : 1.0f;
  return env_share * pick *
         triangle_pdf(p.surface.position, triangle(triangle_index), wi, distance);
}

float Shader::environment_pdf(glm::vec3 wi) const {
  return environment_ ? environment_pick_ * environment_->pdf(wi) : 0.0f;
}

glm::vec3 Shader::escaped(glm::vec3 direction, float bsdf_density, float light_samples) const {
  if (!environment_) return glm::vec3(0.0f);
  glm::vec3 l = environment_->radiance(direction);
  if (light_samples > 0.0f && luminance(l) > 0.0f)
    l *= power_heuristic(bsdf_density, light_samples * environment_pdf(direction));
  return l;
}

glm::vec3 Shader::background(glm::vec3 direction) const {
  if (!environment_ || !environment_->visible()) return glm::vec3(0.0f);
  return environment_->radiance(glm::normalize(direction));
}

ShadingPoint Shader::prepare(const scene::Ray& ray, const scene::Hit& hit) const {
  ShadingPoint p;
  p.surface = scene_.surface_point(hit.triangle, hit.u, hit.v);
  p.material = scene_.material_at(p.surface);
  if (settings_.material_override == MaterialOverride::Lambert) {
    p.material.metallic = 0.0f;
    p.lambert = true;
  }
  p.wo = -glm::normalize(ray.direction);
  p.front_face = glm::dot(p.surface.geometric_normal, p.wo) >= 0.0f;
  p.ng = p.front_face ? p.surface.geometric_normal : -p.surface.geometric_normal;
  // A double-sided surface seen from behind shades with its normals flipped (glTF 3.9.5); the
  // normal texture's perturbation is flipped with them.
  p.n = p.material.normal;
  if (glm::dot(p.surface.shading_normal, p.ng) < 0.0f) p.n = -p.n;
  return p;
}

bool Shader::has_diffuse(const ShadingPoint& p) {
  return p.material.metallic < 1.0f &&
         (p.material.base_color.r > 0.0f || p.material.base_color.g > 0.0f ||
          p.material.base_color.b > 0.0f);
}

glm::vec3 Shader::diffuse_reflectance(const ShadingPoint& p) {
  if (p.lambert) return p.material.diffuse_albedo();
  float n_v = std::max(glm::dot(p.n, p.wo), 0.0f);
  return (1.0f - fresnel_schlick(specular_f0(p.material), n_v)) * p.material.diffuse_albedo();
}

glm::vec3 Shader::emitted(const ShadingPoint& p) const {
  bool emits = p.front_face || scene_.materials[p.surface.material].double_sided;
  return emits ? p.material.emission : glm::vec3(0.0f);
}

bool Shader::visible(glm::vec3 from, glm::vec3 normal, glm::vec3 to_dir, float distance,
                     RayCounters& counters) const {
  ++counters.rays;
  scene::Ray shadow;
  shadow.origin = from + normal * epsilon_;
  // Aim from the offset origin at the light point itself. Along to_dir the ray would end
  // epsilon (1 / cos - 1) beyond the light's surface for a light seen at angle acos(cos) off the
  // normal, so near or grazing area lights shadowed themselves.
  const glm::vec3 d = from + to_dir * distance - shadow.origin;
  const float length = glm::length(d);
  if (!(length > 0.0f)) return true;
  shadow.direction = d / length;
  shadow.tnear = 0.0f;
  shadow.tfar = length * (1.0f - 1e-4f) - epsilon_;
  if (shadow.tfar <= 0.0f) return true;
  return !accel_.occluded(shadow);
}

scene::Ray Shader::spawn(const ShadingPoint& p, glm::vec3 direction) const {
  // From the point itself, skipping the first epsilon along the ray: an origin lifted along the
  // normal would see a nearby light under a smaller solid angle than the light samples do (a
  // panel 2 cm above a floor lost 5% of its light to a 1.4 mm lift) and bias their combination.
  scene::Ray ray;
  ray.origin = p.surface.position;
  ray.direction = direction;
  ray.tnear = epsilon_;
  return ray;
}

glm::vec3 Shader::punctual_diffuse(const ShadingPoint& p, RayCounters& counters) const {
  glm::vec3 sum(0.0f);
  const glm::vec3 x = p.surface.position;
  for (const scene::PunctualLight& light : scene_.lights) {
    glm::vec3 wi;
    float dist;
    if (!direction_to(light, x, &wi, &dist)) continue;
    float cos_x = glm::dot(p.n, wi);
    if (cos_x <= 0.0f || glm::dot(p.ng, wi) <= 0.0f) continue;
    float att = punctual_attenuation(light, wi, dist);
    if (att <= 0.0f || !visible(x, p.ng, wi, dist, counters)) continue;
    sum += light.intensity * (cos_x * att);
  }
  return sum * kInvPi;
}

glm::vec3 Shader::diffuse_estimate(const ShadingPoint& p, int light_samples, int gather_rays,
                                   PathDepth depth, std::uint64_t key, Rng& rng,
                                   RayCounters& counters, float* harmonic_distance) const {
  glm::vec3 sum = punctual_diffuse(p, counters);
  // Each strategy's density is weighed with its sample count (Veach's n_i p_i).
  const float n_light = has_sampled_lights() ? static_cast<float>(light_samples) : 0.0f;
  const float n_gather = static_cast<float>(gather_rays);
  if (n_light > 0.0f)
    sum += light_estimate(p, light_samples, n_light, n_gather, key, rng, counters, 0, nullptr);
  return sum + gather(p, gather_rays, n_light, depth, hash_combine(key, 12), rng, counters,
                      harmonic_distance, 0, nullptr);
}

glm::vec3 Shader::light_estimate(const ShadingPoint& p, int light_samples, float n_light,
                                 float n_gather, std::uint64_t key, Rng& rng,
                                 RayCounters& counters, std::uint32_t round,
                                 SampleMoments* moments) const {
  const glm::vec3 x = p.surface.position;
  const Sobol2D pattern(hash_combine(key, 11));
  glm::vec3 acc(0.0f);
  for (int k = 0; k < light_samples; ++k) {
    LightSample ls;
    const auto index =
        static_cast<std::uint32_t>(k) + round * static_cast<std::uint32_t>(light_samples);
    if (moments) ++moments->count;  // a sample that brings no light counts as 0
    if (!sample_light(p, rng.uniform(), pattern(index), &ls)) continue;
    if (glm::dot(p.n, ls.wi) <= 0.0f || glm::dot(p.ng, ls.wi) <= 0.0f) continue;
    if (!visible(x, p.ng, ls.wi, ls.distance, counters)) continue;
    const glm::vec3 c = diffuse_light(p, ls, n_light, n_gather);
    acc += c;
    if (moments) moments->add(luminance(c));
  }
  return acc / n_light;
}

double Shader::SampleMoments::variance_of_mean() const {
  if (count < 2) return 0.0;
  const double n = static_cast<double>(count);
  const double mean = sum / n;
  return std::max(0.0, sum2 / n - mean * mean) / n;
}

glm::vec3 Shader::diffuse_light(const ShadingPoint& p, const LightSample& ls, float n_light,
                                float n_gather) const {
  // The cosine-weighted integrand over the light sample's solid-angle density.
  const float cosine_pdf = std::max(glm::dot(p.n, ls.wi), 0.0f) * kInvPi;
  return ls.radiance *
         (cosine_pdf / ls.pdf * power_heuristic(n_light * ls.pdf, n_gather * cosine_pdf));
}

glm::vec3 Shader::gather(const ShadingPoint& p, int rays, float n_light, PathDepth depth,
                         std::uint64_t key, Rng& rng, RayCounters& counters,
                         float* harmonic_distance, std::uint32_t first_index,
                         SampleMoments* moments) const {
  if (harmonic_distance) *harmonic_distance = std::numeric_limits<float>::infinity();
  if (rays <= 0) return glm::vec3(0.0f);
  // Cosine-weighted rays, whose pdf cos/pi cancels the integrand's cos/pi.
  const PathDepth next{depth.taken + 1, depth.left - 1, 0};
  const float survival = max_component(diffuse_reflectance(p));
  const float n_gather = static_cast<float>(rays);
  Frame frame(p.n);
  const Sobol2D pattern(key);
  glm::vec3 acc(0.0f);
  float inverse_sum = 0.0f;
  for (int k = 0; k < rays; ++k) {
    const glm::vec3 local = cosine_hemisphere(pattern(first_index + static_cast<std::uint32_t>(k)));
    const glm::vec3 dir = frame.to_world(local);
    if (moments) ++moments->count;  // a ray below the surface or escaping counts as 0
    if (glm::dot(dir, p.ng) <= 0.0f) continue;
    const scene::Ray ray = spawn(p, dir);
    ++counters.rays;
    const scene::Hit hit = accel_.intersect(ray);
    if (!hit.valid()) {  // escaped: the environment's light, if any
      if (environment_) {
        const glm::vec3 c = escaped(dir, n_gather * local.z * kInvPi, n_light);
        acc += c;
        if (moments) moments->add(luminance(c));
      }
      continue;
    }
    inverse_sum += 1.0f / std::max(hit.t, epsilon_);
    const glm::vec3 c = continuation(p, ray, hit, n_gather * local.z * kInvPi, n_light, next,
                                     survival, rng, counters);
    acc += c;
    if (moments) moments->add(luminance(c));
  }
  if (harmonic_distance && inverse_sum > 0.0f)
    *harmonic_distance = n_gather / inverse_sum;
  return acc / n_gather;
}

glm::vec3 Shader::continuation(const ShadingPoint& p, const scene::Ray& ray,
                               const scene::Hit& hit, float bsdf_density, float light_samples,
                               PathDepth next, float survival, Rng& rng,
                               RayCounters& counters) const {
  const ShadingPoint q = prepare(ray, hit);
  glm::vec3 l = emitted(q);
  if (l.x + l.y + l.z > 0.0f && light_samples > 0.0f)
    l *= power_heuristic(bsdf_density,
                         light_samples * light_pdf(p, hit.triangle, ray.direction, hit.t));
  if (next.left < 0) return l;  // traced for its emission alone (direct light at p)
  // Russian roulette from the third vertex on, with the step's throughput as the probability.
  if (next.taken >= 2) {
    const float q_survive = std::clamp(survival, 0.05f, 1.0f);
    if (q_survive < 1.0f) {
      if (rng.uniform() >= q_survive) return l;
      return l + reflected(q, next, rng, counters) / q_survive;
    }
  }
  return l + reflected(q, next, rng, counters);
}

glm::vec3 Shader::reflected(const ShadingPoint& q, PathDepth depth, Rng& rng,
                            RayCounters& counters) const {
  // One light sample serves both lobes (one shadow ray), each lobe weighted against its own ray.
  const bool diffuse = has_diffuse(q);
  const GgxLobe lobe = specular_lobe(q, depth);
  const float n_gather = diffuse && depth.left >= 1 ? 1.0f : 0.0f;
  const glm::vec3 rho = diffuse ? diffuse_reflectance(q) : glm::vec3(0.0f);
  glm::vec3 l(0.0f);
  if (diffuse) l += rho * punctual_diffuse(q, counters);
  if (lobe.keep > 0.0f) l += specular_punctual(q, lobe, counters);
  LightSample ls;
  if (has_sampled_lights() &&
      sample_light(q, rng.uniform(), glm::vec2(rng.uniform(), rng.uniform()), &ls) &&
      glm::dot(q.n, ls.wi) > 0.0f && glm::dot(q.ng, ls.wi) > 0.0f &&
      visible(q.surface.position, q.ng, ls.wi, ls.distance, counters)) {
    if (diffuse) l += rho * diffuse_light(q, ls, 1.0f, n_gather);
    if (lobe.keep > 0.0f) l += specular_light(q, lobe, ls);
  }
  if (n_gather > 0.0f)
    l += rho * gather(q, 1, 1.0f, PathDepth{depth.taken, depth.left, 0}, draw_key(rng), rng,
                      counters, nullptr, 0, nullptr);
  if (lobe.keep > 0.0f) l += specular_ray(q, lobe, depth, rng, counters);
  return l;
}

glm::vec3 Shader::diffuse_illumination(const ShadingPoint& p, std::uint64_t key, Rng& rng,
                                       RayCounters& counters, float* harmonic_distance) const {
  ++counters.shading_points;
  return diffuse_estimate(p, settings_.light_samples, settings_.gather_rays,
                          PathDepth{0, settings_.bounces, 0}, key, rng, counters,
                          harmonic_distance);
}

glm::vec3 Shader::refined_diffuse_illumination(const ShadingPoint& p, std::uint64_t key,
                                               Rng& rng, RayCounters& counters,
                                               float* harmonic_distance, float relative_error,
                                               int max_rounds) const {
  if (max_rounds <= 1) return diffuse_illumination(p, key, rng, counters, harmonic_distance);
  ++counters.shading_points;
  const PathDepth depth{0, settings_.bounces, 0};
  const int light_samples = settings_.light_samples, gather_rays = settings_.gather_rays;
  // The MIS weights keep the per-round counts: each estimator's rounds average unbiasedly.
  const float n_light = has_sampled_lights() ? static_cast<float>(light_samples) : 0.0f;
  const float n_gather = static_cast<float>(gather_rays);
  const glm::vec3 punctual = punctual_diffuse(p, counters);
  SampleMoments light_moments, gather_moments;
  glm::vec3 light(0.0f), indirect(0.0f);
  std::uint64_t light_cost = 0, gather_cost = 0;  // rays each estimator has cast
  int light_rounds = 0, gather_rounds = 0;
  auto light_round = [&] {
    const std::uint64_t before = counters.rays;
    light += light_estimate(p, light_samples, n_light, n_gather, key, rng, counters,
                            static_cast<std::uint32_t>(light_rounds++), &light_moments);
    light_cost += counters.rays - before;
  };
  auto gather_round = [&] {
    const std::uint64_t before = counters.rays;
    const auto round = static_cast<std::uint32_t>(gather_rounds++);
    indirect += gather(p, gather_rays, n_light, depth, hash_combine(key, 12), rng, counters,
                       round == 0 ? harmonic_distance : nullptr,
                       round * static_cast<std::uint32_t>(gather_rays), &gather_moments);
    gather_cost += counters.rays - before;
  };
  // Each estimator starts with two samples at least, so that its spread is known.
  if (n_light > 0.0f)
    for (int r = 0; r < (light_samples == 1 ? 2 : 1); ++r) light_round();
  for (int r = 0; r < (gather_rays == 1 ? 2 : 1); ++r) gather_round();
  auto estimate = [&] {
    glm::vec3 e = punctual;
    if (light_rounds > 0) e += light / static_cast<float>(light_rounds);
    return e + indirect / static_cast<float>(gather_rounds);
  };
  for (;;) {
    const double vl = light_rounds > 0 ? light_moments.variance_of_mean() : 0.0;
    const double vg = gather_moments.variance_of_mean();
    const double target = relative_error * luminance(estimate());
    if (!(vl + vg > target * target)) break;
    const bool more_light = light_rounds > 0 && light_rounds < max_rounds && vl > 0.0;
    const bool more_gather = gather_rounds < max_rounds && vg > 0.0;
    if (!more_light && !more_gather) break;
    // Doubling an estimator's rounds halves its variance for as many rays again: take the one
    // that removes the most variance per ray.
    const double light_rays = static_cast<double>(std::max<std::uint64_t>(light_cost, 1));
    const double gather_rays_cast = static_cast<double>(std::max<std::uint64_t>(gather_cost, 1));
    const bool pick_light =
        more_light && (!more_gather || vl / light_rays > vg / gather_rays_cast);
    if (pick_light) {
      for (int r = light_rounds, end = 2 * light_rounds; r < end; ++r) light_round();
    } else {
      for (int r = gather_rounds, end = 2 * gather_rounds; r < end; ++r) gather_round();
    }
  }
  return estimate();
}

glm::vec3 Shader::shade(const ShadingPoint& p, glm::vec3 diffuse_illum, float lobe_u, Rng& rng,
                        RayCounters& counters) const {
  glm::vec3 l = emitted(p);
  const bool diffuse = has_diffuse(p);
  const glm::vec3 rho = diffuse ? diffuse_reflectance(p) : glm::vec3(0.0f);
  if (diffuse) l += rho * diffuse_illum;
  // The specular lobe at a camera hit, where no diffuse light sample is taken to share (the
  // diffuse light may come from the cache): a light sample of its own and the lobe's ray.
  const PathDepth depth{0, settings_.bounces, 0};
  const GgxLobe lobe = specular_lobe(p, depth);
  if (lobe.keep <= 0.0f) return l;
  const float p_lobe = diffuse ? rough_lobe_probability(lobe, luminance(rho)) : 1.0f;
  if (p_lobe < 1.0f) {
    if (lobe_u >= p_lobe) return l;
    return l + specular_at_camera_hit(p, lobe, depth, rng, counters) / p_lobe;
  }
  return l + specular_at_camera_hit(p, lobe, depth, rng, counters);
}

float Shader::rough_lobe_probability(const GgxLobe& lobe, float diffuse_luminance) const {
  // A rough dielectric lobe (roughness >= kRoughLobeAlpha) reflects a few percent of a broad
  // cone of light: its share of the outgoing radiance is about F / (F + (1 - F) c), the
  // diffuse lobe seeing the same surroundings, and its estimate is bounded by the same light
  // the diffuse term already holds. Where the diffuse light comes from the cache, the lobe's
  // light sample and ray are most of a lens ray's cost, so the lobe is evaluated on a fraction
  // of the lens rays, in proportion to its share (unbiased: weighted by the inverse).
  if (lobe.alpha < kRoughLobeAlpha || settings_.rough_lobe_rate <= 0.0f) return 1.0f;
  const float share = lobe.fresnel / std::max(lobe.fresnel + diffuse_luminance, 1e-6f);
  return std::clamp(settings_.rough_lobe_rate * share, kMinRoughLobeProbability, 1.0f);
}

glm::vec3 Shader::specular_at_camera_hit(const ShadingPoint& p, const GgxLobe& lobe,
                                         PathDepth depth, Rng& rng,
                                         RayCounters& counters) const {
  glm::vec3 l = specular_punctual(p, lobe, counters);
  LightSample ls;
  if (has_sampled_lights() &&
      sample_light(p, rng.uniform(), glm::vec2(rng.uniform(), rng.uniform()), &ls) &&
      glm::dot(p.ng, ls.wi) > 0.0f) {
    const glm::vec3 f = specular_light(p, lobe, ls);
    if (luminance(f) > 0.0f && visible(p.surface.position, p.ng, ls.wi, ls.distance, counters))
      l += f;
  }
  return l + specular_ray(p, lobe, depth, rng, counters);
}

GgxLobe Shader::specular_lobe(const ShadingPoint& p, PathDepth depth) const {
  GgxLobe lobe;
  lobe.n_v = glm::dot(p.n, p.wo);
  if (p.lambert || depth.glossy >= settings_.specular_depth || lobe.n_v <= 1e-6f)
    return lobe;  // keep 0
  lobe.alpha = ggx_alpha(p.material.roughness);
  lobe.f0 = specular_f0(p.material);
  // A rough dielectric reflects about 4% (F0 = 0.04) yet would cost a reflection ray at every
  // vertex, so its ray is traced with probability `keep` (metals and grazing angles, F -> 1,
  // keep 1). The light sample is always taken, and in the MIS weights the ray's density is keep
  // times its pdf: a ray that meets a light is then weighted as the rare strategy it is. (Under a
  // roulette of the whole lobe, grazing reflection rays that met the light were fireflies.)
  lobe.fresnel = luminance(fresnel_schlick(lobe.f0, lobe.n_v));
  lobe.keep = std::clamp(4.0f * lobe.fresnel, 0.125f, 1.0f);
  return lobe;
}

glm::vec3 Shader::specular_punctual(const ShadingPoint& p, const GgxLobe& lobe,
                                    RayCounters& counters) const {
  // Punctual lights cannot be hit by sampled rays: evaluate the BRDF towards them directly.
  glm::vec3 result(0.0f);
  const glm::vec3 x = p.surface.position;
  for (const scene::PunctualLight& light : scene_.lights) {
    glm::vec3 wi;
    float dist, pdf;
    if (!direction_to(light, x, &wi, &dist) || glm::dot(p.ng, wi) <= 0.0f) continue;
    const glm::vec3 f = lobe.eval(p.n, p.wo, wi, &pdf);
    const float att = punctual_attenuation(light, wi, dist);
    if (luminance(f) <= 0.0f || att <= 0.0f || !visible(x, p.ng, wi, dist, counters)) continue;
    result += f * light.intensity * att;
  }
  return result;
}

glm::vec3 Shader::specular_light(const ShadingPoint& p, const GgxLobe& lobe,
                                 const LightSample& ls) const {
  float pdf;
  const glm::vec3 f = lobe.eval(p.n, p.wo, ls.wi, &pdf);
  return f * ls.radiance * (power_heuristic(ls.pdf, lobe.keep * pdf) / ls.pdf);
}

glm::vec3 Shader::specular_ray(const ShadingPoint& p, const GgxLobe& lobe, PathDepth depth,
                               Rng& rng, RayCounters& counters) const {
  if (lobe.keep < 1.0f && rng.uniform() >= lobe.keep) return glm::vec3(0.0f);
  // The visible normals (render/ggx.h): f cos / pdf is F G1(n.l), at most 1. Sampling the
  // half-vector by D (n.h) gave F G1(n.v) G1(n.l) (v.h) / ((n.v)(n.h)), above 5 at grazing views
  // of a rough floor: fireflies where such a ray met a small bright lamp.
  const float u1 = rng.uniform(), u2 = rng.uniform();
  const float alpha = lobe.alpha, n_v = lobe.n_v;
  const Frame frame(p.n);
  const glm::vec3 h_local = sample_ggx_visible_normal(
      glm::vec3(glm::dot(p.wo, frame.t), glm::dot(p.wo, frame.b), n_v), alpha, {u1, u2});
  const glm::vec3 h = frame.to_world(h_local);
  const float v_h = glm::dot(p.wo, h);
  if (v_h <= 0.0f) return glm::vec3(0.0f);
  const glm::vec3 wi = 2.0f * v_h * h - p.wo;
  const float n_l = glm::dot(p.n, wi);
  if (n_l <= 0.0f || glm::dot(p.ng, wi) <= 0.0f) return glm::vec3(0.0f);
  // f cos / pdf = F G1(n.l), over the ray's probability.
  const glm::vec3 weight = fresnel_schlick(lobe.f0, v_h) * (smith_g1(n_l, alpha) / lobe.keep);
  const float pdf = lobe.keep * ggx_vndf_pdf(h_local.z, n_v, alpha);
  const scene::Ray ray = spawn(p, wi);
  ++counters.rays;
  const scene::Hit hit = accel_.intersect(ray);
  // One light sample is taken beside the lobe's ray (reflected(), specular_at_camera_hit()).
  if (!hit.valid())
    return environment_ ? weight * escaped(wi, pdf, 1.0f) : glm::vec3(0.0f);
  const PathDepth next{depth.taken + 1, depth.left - 1, depth.glossy + 1};
  return weight * continuation(p, ray, hit, pdf, 1.0f, next, max_component(weight), rng, counters);
}

}  // namespace dofcache::render
