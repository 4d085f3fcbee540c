#include "dofcache/render/shading.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include "dofcache/core/error.h"
#include "dofcache/lens/thin_lens.h"
#include "dofcache/render/sampler.h"

namespace dofcache::render {
namespace {

constexpr float kPi = 3.14159265358979f;
constexpr float kInvPi = 1.0f / kPi;

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

float ggx_d(float n_h, float alpha) {
  float a2 = alpha * alpha;
  float d = n_h * n_h * (a2 - 1.0f) + 1.0f;
  return a2 / (kPi * d * d);
}

float smith_g1(float n_x, float alpha) {
  float a2 = alpha * alpha;
  return 2.0f * n_x / (n_x + std::sqrt(a2 + (1.0f - a2) * n_x * n_x));
}

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

}  // namespace

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
}

Shader::Shader(const scene::Scene& scene, const scene::Accel& accel,
               const ShadingSettings& settings)
    : scene_(scene), accel_(accel), settings_(settings), light_sampler_(scene) {
  float extent = std::max(glm::length(scene.bounds.lower), glm::length(scene.bounds.upper));
  epsilon_ = 1e-4f * std::max(1.0f, extent);
  triangle_emitter_.assign(scene.mesh.triangles.size(), -1);
  for (std::size_t e = 0; e < scene.emitters.size(); ++e)
    triangle_emitter_[scene.emitters[e].triangle] = static_cast<int>(e);
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

float Shader::emitter_pdf(const ShadingPoint& p, std::uint32_t triangle, glm::vec3 wi,
                          float distance) const {
  int e = triangle_emitter_[triangle];
  if (e < 0) return 0.0f;
  const scene::Emitter& em = scene_.emitters[static_cast<std::size_t>(e)];
  float pick = light_sampler_.probability(p.surface.position, p.n, static_cast<std::size_t>(e));
  const glm::uvec3 tri = scene_.mesh.triangles[triangle];
  const auto& P = scene_.mesh.positions;
  glm::vec3 nl = glm::normalize(glm::cross(P[tri.y] - P[tri.x], P[tri.z] - P[tri.x]));
  float cos_l = std::abs(glm::dot(nl, wi));
  if (cos_l <= 0.0f || em.area <= 0.0f) return 0.0f;
  return pick * distance * distance / (em.area * cos_l);
}

ShadingPoint Shader::prepare(const scene::Ray& ray, const scene::Hit& hit) const {
  ShadingPoint p;
  p.surface = scene_.surface_point(hit.triangle, hit.u, hit.v);
  p.material = scene_.material_at(p.surface);
  p.wo = -glm::normalize(ray.direction);
  p.front_face = glm::dot(p.surface.geometric_normal, p.wo) >= 0.0f;
  p.ng = p.front_face ? p.surface.geometric_normal : -p.surface.geometric_normal;
  p.n = p.surface.shading_normal;
  if (glm::dot(p.n, p.ng) < 0.0f) p.n = -p.n;
  return p;
}

bool Shader::has_diffuse(const ShadingPoint& p) {
  return p.material.metallic < 1.0f &&
         (p.material.base_color.r > 0.0f || p.material.base_color.g > 0.0f ||
          p.material.base_color.b > 0.0f);
}

glm::vec3 Shader::diffuse_reflectance(const ShadingPoint& p) {
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

glm::vec3 Shader::direct_light(const ShadingPoint& p, int samples, std::uint64_t key, Rng& rng,
                               RayCounters& counters) const {
  glm::vec3 sum(0.0f);
  const glm::vec3 x = p.surface.position;
  // Area lights: stratified points on emissive triangles chosen by the light sampler.
  if (!scene_.emitters.empty() && samples > 0) {
    glm::vec3 area_sum(0.0f);
    for (int k = 0; k < samples; ++k) {
      float pick;
      std::size_t e;
      if (!light_sampler_.sample(x, p.n, rng.uniform(), &e, &pick)) continue;
      const scene::Emitter& em = scene_.emitters[e];
      glm::vec2 u = sobol_2d(static_cast<std::uint32_t>(k), key);
      float su = std::sqrt(u.x);
      float b1 = 1.0f - su, b2 = u.y * su;
      const glm::uvec3 tri = scene_.mesh.triangles[em.triangle];
      const auto& P = scene_.mesh.positions;
      glm::vec3 q = b1 * P[tri.x] + b2 * P[tri.y] + (1.0f - b1 - b2) * P[tri.z];
      glm::vec3 nl = glm::cross(P[tri.y] - P[tri.x], P[tri.z] - P[tri.x]);
      nl = glm::normalize(nl);
      glm::vec3 d = q - x;
      float dist2 = glm::dot(d, d);
      if (dist2 <= 0.0f) continue;
      float dist = std::sqrt(dist2);
      glm::vec3 wi = d / dist;
      float cos_x = glm::dot(p.n, wi);
      float cos_l = -glm::dot(nl, wi);
      if (scene_.materials[scene_.mesh.triangle_material[em.triangle]].double_sided)
        cos_l = std::abs(cos_l);
      if (cos_x <= 0.0f || cos_l <= 0.0f || glm::dot(p.ng, wi) <= 0.0f) continue;
      if (!visible(x, p.ng, wi, dist, counters)) continue;
      area_sum += em.radiance * (cos_x * cos_l * em.area / (dist2 * pick));
    }
    sum += area_sum / static_cast<float>(samples);
  }
  // Punctual lights: one shadow ray each (they are points).
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

glm::vec3 Shader::indirect_light(const ShadingPoint& p, int rays, int bounces_left,
                                 std::uint64_t key, Rng& rng, RayCounters& counters,
                                 float* harmonic_distance) const {
  if (harmonic_distance) *harmonic_distance = std::numeric_limits<float>::infinity();
  if (rays <= 0 || bounces_left <= 0) return glm::vec3(0.0f);
  float inverse_sum = 0.0f;
  // Cosine-weighted gather: the pdf cos/pi cancels, so E/pi is the mean incoming radiance.
  Frame frame(p.n);
  glm::vec3 sum(0.0f);
  for (int k = 0; k < rays; ++k) {
    glm::vec3 dir = frame.to_world(cosine_hemisphere(sobol_2d(static_cast<std::uint32_t>(k), key)));
    if (glm::dot(dir, p.ng) <= 0.0f) continue;
    scene::Ray ray;
    ray.origin = p.surface.position + p.ng * epsilon_;
    ray.direction = dir;
    ++counters.rays;
    scene::Hit hit = accel_.intersect(ray);
    if (!hit.valid()) continue;
    inverse_sum += 1.0f / std::max(hit.t, epsilon_);
    ShadingPoint q = prepare(ray, hit);
    if (!has_diffuse(q)) continue;  // emission is counted by direct light sampling
    std::uint64_t sub = hash_combine(key, static_cast<std::uint64_t>(k) + 1);
    glm::vec3 e = direct_light(q, 1, sub, rng, counters);
    if (bounces_left > 1) e += indirect_light(q, 1, bounces_left - 1, sub, rng, counters);
    sum += diffuse_reflectance(q) * e;
  }
  if (harmonic_distance && inverse_sum > 0.0f)
    *harmonic_distance = static_cast<float>(rays) / inverse_sum;
  return sum / static_cast<float>(rays);
}

glm::vec3 Shader::diffuse_illumination(const ShadingPoint& p, std::uint64_t key, Rng& rng,
                                       RayCounters& counters, float* harmonic_distance) const {
  ++counters.shading_points;
  return direct_light(p, settings_.light_samples, hash_combine(key, 11), rng, counters) +
         indirect_light(p, settings_.gather_rays, settings_.bounces, hash_combine(key, 12), rng,
                        counters, harmonic_distance);
}

glm::vec3 Shader::shade(const ShadingPoint& p, glm::vec3 diffuse_illum, Rng& rng,
                        RayCounters& counters, const DiffuseLookup* cached, int depth) const {
  glm::vec3 l = emitted(p);
  if (has_diffuse(p)) l += diffuse_reflectance(p) * diffuse_illum;
  return l + specular(p, rng, counters, cached, depth);
}

glm::vec3 Shader::specular(const ShadingPoint& p, Rng& rng, RayCounters& counters,
                           const DiffuseLookup* cached, int depth) const {
  if (depth >= settings_.specular_depth) return glm::vec3(0.0f);
  const float alpha = ggx_alpha(p.material.roughness);
  const glm::vec3 f0 = specular_f0(p.material);
  const float n_v = glm::dot(p.n, p.wo);
  if (n_v <= 1e-6f) return glm::vec3(0.0f);
  // Russian roulette on weak lobes: a rough dielectric reflects about 4% (F0 = 0.04) yet would
  // cost a shadow ray and a reflection ray per camera ray. Evaluating it with probability q and
  // dividing by q keeps the estimate unbiased; metals and grazing angles (F -> 1) keep q = 1.
  const float keep = std::clamp(4.0f * luminance(fresnel_schlick(f0, n_v)), 0.125f, 1.0f);
  if (keep < 1.0f && rng.uniform() >= keep) return glm::vec3(0.0f);
  const float inv_q = 1.0f / keep;
  glm::vec3 result(0.0f);

  // Punctual lights cannot be hit by sampled rays: evaluate the BRDF towards them directly.
  for (const scene::PunctualLight& light : scene_.lights) {
    glm::vec3 wi;
    float dist;
    if (!direction_to(light, p.surface.position, &wi, &dist)) continue;
    float n_l = glm::dot(p.n, wi);
    if (n_l <= 0.0f || glm::dot(p.ng, wi) <= 0.0f) continue;
    glm::vec3 h = glm::normalize(wi + p.wo);
    float d = ggx_d(std::max(glm::dot(p.n, h), 0.0f), alpha);
    float g = smith_g1(n_v, alpha) * smith_g1(n_l, alpha);
    glm::vec3 f = fresnel_schlick(f0, glm::dot(p.wo, h));
    float att = punctual_attenuation(light, wi, dist);
    if (att <= 0.0f || !visible(p.surface.position, p.ng, wi, dist, counters)) continue;
    result += f * (d * g / (4.0f * n_v)) * light.intensity * att;  // f_spec * n_l * E_light
  }

  // Area lights by both strategies, combined with the power heuristic (Veach 1997): light
  // sampling wins on rough lobes, BRDF sampling on sharp ones; either alone leaves fireflies.
  auto brdf_pdf = [&](float n_h, float v_h) { return ggx_d(n_h, alpha) * n_h / (4.0f * v_h); };
  auto power = [](float a, float b) { return a * a / (a * a + b * b); };
  if (!scene_.emitters.empty()) {
    float pick, u_light = rng.uniform();
    float su = std::sqrt(rng.uniform()), v = rng.uniform();
    std::size_t e;
    if (light_sampler_.sample(p.surface.position, p.n, u_light, &e, &pick)) {
      const scene::Emitter& em = scene_.emitters[e];
      float b1 = 1.0f - su, b2 = v * su;
      const glm::uvec3 tri = scene_.mesh.triangles[em.triangle];
      const auto& P = scene_.mesh.positions;
      glm::vec3 q = b1 * P[tri.x] + b2 * P[tri.y] + (1.0f - b1 - b2) * P[tri.z];
      glm::vec3 d = q - p.surface.position;
      float dist = glm::length(d);
      glm::vec3 wi = d / std::max(dist, 1e-20f);
      float n_l = glm::dot(p.n, wi);
      float pdf_light = dist > 0.0f ? emitter_pdf(p, em.triangle, wi, dist) : 0.0f;
      bool faces = scene_.materials[scene_.mesh.triangle_material[em.triangle]].double_sided ||
                   glm::dot(glm::cross(P[tri.y] - P[tri.x], P[tri.z] - P[tri.x]), wi) < 0.0f;
      if (n_l > 0.0f && pdf_light > 0.0f && faces && glm::dot(p.ng, wi) > 0.0f) {
        glm::vec3 h = glm::normalize(wi + p.wo);
        float n_h = std::max(glm::dot(p.n, h), 1e-6f), v_h = std::max(glm::dot(p.wo, h), 1e-6f);
        float d_h = ggx_d(n_h, alpha);
        glm::vec3 f = fresnel_schlick(f0, v_h) *
                      (d_h * smith_g1(n_v, alpha) * smith_g1(n_l, alpha) / (4.0f * n_v * n_l));
        if (luminance(f) > 0.0f && visible(p.surface.position, p.ng, wi, dist, counters))
          result += f * em.radiance * (n_l / pdf_light) * power(pdf_light, brdf_pdf(n_h, v_h));
      }
    }
  }

  // Everything else (and area lights again): one GGX-sampled reflection ray.
  Frame frame(p.n);
  float u1 = rng.uniform(), u2 = rng.uniform();
  float tan2 = alpha * alpha * u1 / std::max(1.0f - u1, 1e-7f);
  float cos_h = 1.0f / std::sqrt(1.0f + tan2);
  float sin_h = std::sqrt(std::max(0.0f, 1.0f - cos_h * cos_h));
  float phi = 2.0f * kPi * u2;
  glm::vec3 h = frame.to_world({sin_h * std::cos(phi), sin_h * std::sin(phi), cos_h});
  float v_h = glm::dot(p.wo, h);
  if (v_h <= 0.0f) return result * inv_q;
  glm::vec3 wi = 2.0f * v_h * h - p.wo;
  float n_l = glm::dot(p.n, wi);
  if (n_l <= 0.0f || glm::dot(p.ng, wi) <= 0.0f) return result * inv_q;
  // f cos / pdf with pdf = D (n.h) / (4 v.h): F G (v.h) / ((n.v)(n.h)).
  glm::vec3 weight = fresnel_schlick(f0, v_h) *
                     (smith_g1(n_v, alpha) * smith_g1(n_l, alpha) * v_h / (n_v * cos_h));
  if (luminance(weight) < 1e-4f) return result * inv_q;

  scene::Ray ray;
  ray.origin = p.surface.position + p.ng * epsilon_;
  ray.direction = wi;
  ++counters.rays;
  scene::Hit hit = accel_.intersect(ray);
  if (!hit.valid()) return result * inv_q;
  ShadingPoint q = prepare(ray, hit);
  glm::vec3 le = emitted(q);
  if (le.x + le.y + le.z > 0.0f) {
    float pdf_light = emitter_pdf(p, hit.triangle, wi, hit.t);
    le *= power(brdf_pdf(cos_h, v_h), pdf_light);
  }
  // Seen in a reflection, diffuse light comes from the cache if it has it, else from an estimate
  // cheaper than at primary hits (a reflection is one of many lens rays averaged per pixel).
  glm::vec3 e(0.0f);
  if (has_diffuse(q) && !(cached && cached->lookup(q, &e))) {
    std::uint64_t key = hash_combine(rng.next_u32(), rng.next_u32());
    e = direct_light(q, 1, key, rng, counters) +
        indirect_light(q, std::max(1, settings_.gather_rays / 8), settings_.bounces, key + 1, rng,
                       counters);
  }
  glm::vec3 reflected = le + specular(q, rng, counters, cached, depth + 1);
  if (has_diffuse(q)) reflected += diffuse_reflectance(q) * e;
  return (result + weight * reflected) * inv_q;
}

}  // namespace dofcache::render
