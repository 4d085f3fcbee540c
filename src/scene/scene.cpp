#include "dofcache/scene/scene.h"

#include <algorithm>
#include <cassert>
#include <cmath>

#include <glm/geometric.hpp>

#include "dofcache/core/error.h"

namespace dofcache::scene {
namespace {

// Texel index for integer coordinate i on an axis of n texels (glTF sampler wrap modes).
int wrap_index(long long i, int n, Wrap wrap) {
  switch (wrap) {
    case Wrap::ClampToEdge:
      return static_cast<int>(std::clamp<long long>(i, 0, n - 1));
    case Wrap::MirroredRepeat: {
      long long period = 2LL * n;
      long long m = ((i % period) + period) % period;
      return static_cast<int>(m < n ? m : period - 1 - m);
    }
    case Wrap::Repeat:
    default:
      return static_cast<int>(((i % n) + n) % n);
  }
}

// Texture coordinates far outside [0,1] (or not finite) would overflow the integer texel index;
// every wrap mode gives the same texel for coordinates 2^20 periods apart, so fold them first.
double fold(float t) {
  if (!std::isfinite(t)) return 0.0;
  constexpr double kPeriod = 1 << 20;
  double d = static_cast<double>(t);
  return std::abs(d) < kPeriod ? d : std::fmod(d, kPeriod);
}

float srgb_to_linear(float c) {
  return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}

glm::vec4 decode_srgb(glm::vec4 t) {
  return {srgb_to_linear(t.r), srgb_to_linear(t.g), srgb_to_linear(t.b), t.a};
}

template <class Decode>
glm::vec4 filtered(const Texture& tex, glm::vec2 uv, Decode decode) {
  if (tex.width <= 0 || tex.height <= 0 || tex.texels.empty()) return glm::vec4(1.0f);
  auto texel = [&](long long x, long long y) {
    int ix = wrap_index(x, tex.width, tex.wrap_s);
    int iy = wrap_index(y, tex.height, tex.wrap_t);
    return decode(tex.texels[static_cast<std::size_t>(iy) * tex.width + ix]);
  };
  double x = fold(uv.x) * tex.width, y = fold(uv.y) * tex.height;
  if (tex.nearest)
    return texel(static_cast<long long>(std::floor(x)), static_cast<long long>(std::floor(y)));
  // Bilinear between the four texel centres around (x, y); centres sit at integer + 0.5.
  x -= 0.5;
  y -= 0.5;
  double fx = std::floor(x), fy = std::floor(y);
  auto x0 = static_cast<long long>(fx), y0 = static_cast<long long>(fy);
  auto tx = static_cast<float>(x - fx), ty = static_cast<float>(y - fy);
  glm::vec4 top = (1.0f - tx) * texel(x0, y0) + tx * texel(x0 + 1, y0);
  glm::vec4 bottom = (1.0f - tx) * texel(x0, y0 + 1) + tx * texel(x0 + 1, y0 + 1);
  return (1.0f - ty) * top + ty * bottom;
}

glm::vec3 safe_normalize(glm::vec3 v, glm::vec3 fallback) {
  float len = glm::length(v);
  return len > 0.0f && std::isfinite(len) ? v / len : fallback;
}

}  // namespace

// KHR_texture_transform: scale, then rotate, then offset. The rotation is counter-clockwise as the
// UV map is drawn (v down), i.e. the matrix [c s; -s c] that the extension's sample model and the
// common viewers use (KhronosGroup/glTF#1563: the extension's GLSL listing has the transpose).
glm::vec2 TextureRef::apply(glm::vec2 uv) const {
  glm::vec2 s = scale * uv;
  float c = std::cos(rotation), r = std::sin(rotation);
  return offset + glm::vec2(c * s.x + r * s.y, -r * s.x + c * s.y);
}

glm::vec4 Texture::sample(glm::vec2 uv) const {
  return filtered(*this, uv, [](glm::vec4 t) { return t; });
}

glm::vec4 Texture::sample_srgb(glm::vec2 uv) const { return filtered(*this, uv, decode_srgb); }

void Bounds::extend(glm::vec3 p) {
  lower = glm::min(lower, p);
  upper = glm::max(upper, p);
}

float Bounds::diagonal() const {
  if (lower.x > upper.x || lower.y > upper.y || lower.z > upper.z) return 0.0f;  // empty
  return glm::length(upper - lower);
}

SurfacePoint Scene::surface_point(std::uint32_t triangle, float u, float v) const {
  assert(triangle < mesh.triangles.size());
  const glm::uvec3& t = mesh.triangles[triangle];
  float w = 1.0f - u - v;
  const glm::vec3 &p0 = mesh.positions[t.x], &p1 = mesh.positions[t.y], &p2 = mesh.positions[t.z];

  SurfacePoint sp;
  sp.triangle = triangle;
  sp.material = triangle < mesh.triangle_material.size() ? mesh.triangle_material[triangle] : 0;
  sp.position = w * p0 + u * p1 + v * p2;
  // Counter-clockwise winding is the front face in glTF.
  sp.geometric_normal = safe_normalize(glm::cross(p1 - p0, p2 - p0), glm::vec3(0.0f, 0.0f, 1.0f));
  if (mesh.normals.size() == mesh.positions.size()) {
    glm::vec3 n = w * mesh.normals[t.x] + u * mesh.normals[t.y] + v * mesh.normals[t.z];
    sp.shading_normal = safe_normalize(n, sp.geometric_normal);
  } else {
    sp.shading_normal = sp.geometric_normal;
  }
  if (mesh.uv0.size() == mesh.positions.size())
    sp.uv[0] = w * mesh.uv0[t.x] + u * mesh.uv0[t.y] + v * mesh.uv0[t.z];
  if (mesh.uv1.size() == mesh.positions.size())
    sp.uv[1] = w * mesh.uv1[t.x] + u * mesh.uv1[t.y] + v * mesh.uv1[t.z];
  if (mesh.colors.size() == mesh.positions.size())
    sp.color = w * mesh.colors[t.x] + u * mesh.colors[t.y] + v * mesh.colors[t.z];
  if (mesh.tangents.size() == mesh.positions.size())
    sp.tangent = w * mesh.tangents[t.x] + u * mesh.tangents[t.y] + v * mesh.tangents[t.z];
  return sp;
}

MaterialPoint Scene::material_at(const SurfacePoint& sp) const {
  assert(sp.material < materials.size());
  const Material& m = materials[sp.material];
  auto texture = [&](const TextureRef& ref) -> const Texture* {
    return ref.index >= 0 && static_cast<std::size_t>(ref.index) < textures.size()
               ? &textures[static_cast<std::size_t>(ref.index)]
               : nullptr;
  };
  auto uv = [&](const TextureRef& ref) {
    glm::vec2 t = sp.uv[ref.texcoord == 1 ? 1 : 0];
    return ref.has_transform() ? ref.apply(t) : t;
  };

  MaterialPoint mp;
  mp.base_color = glm::vec3(m.base_color) * glm::vec3(sp.color);
  mp.normal = sp.shading_normal;
  mp.metallic = m.metallic;
  mp.roughness = m.roughness;
  mp.emission = m.emissive;
  if (const Texture* t = texture(m.base_color_texture))
    mp.base_color *= glm::vec3(t->sample_srgb(uv(m.base_color_texture)));
  if (const Texture* t = texture(m.metallic_roughness_texture)) {
    glm::vec4 mr = t->sample(uv(m.metallic_roughness_texture));  // linear: G roughness, B metallic
    mp.roughness *= mr.g;
    mp.metallic *= mr.b;
  }
  if (const Texture* t = texture(m.emissive_texture))
    mp.emission *= glm::vec3(t->sample_srgb(uv(m.emissive_texture)));
  const Texture* normal_map = texture(m.normal_texture);
  if (normal_map && sp.tangent != glm::vec4(0.0f)) {
    // Tangent frame at the point: the interpolated tangent made orthogonal to the shading
    // normal (Gram-Schmidt), the bitangent from the handedness (glTF 3.7.2.1).
    glm::vec3 n = sp.shading_normal;
    glm::vec3 t = glm::vec3(sp.tangent) - glm::dot(glm::vec3(sp.tangent), n) * n;
    float len = glm::length(t);
    if (len > 1e-6f && std::isfinite(len)) {
      t /= len;
      glm::vec3 b = (sp.tangent.w < 0.0f ? -1.0f : 1.0f) * glm::cross(n, t);
      glm::vec3 c = 2.0f * glm::vec3(normal_map->sample(uv(m.normal_texture))) - 1.0f;
      c.x *= m.normal_scale;
      c.y *= m.normal_scale;
      mp.normal = safe_normalize(c.x * t + c.y * b + c.z * n, n);
    }
  }
  mp.metallic = std::clamp(mp.metallic, 0.0f, 1.0f);
  mp.roughness = std::clamp(mp.roughness, 0.0f, 1.0f);
  return mp;
}

float Scene::alpha_at(std::uint32_t triangle, float u, float v) const {
  const Material& m = materials[mesh.triangle_material[triangle]];
  if (m.alpha_mode == AlphaMode::Opaque) return 1.0f;
  float alpha = m.base_color.a;
  const bool textured = m.base_color_texture.index >= 0 &&
                        static_cast<std::size_t>(m.base_color_texture.index) < textures.size();
  if (!textured && mesh.colors.empty()) return alpha;
  SurfacePoint sp = surface_point(triangle, u, v);
  alpha *= sp.color.a;
  if (textured) {
    const TextureRef& ref = m.base_color_texture;
    glm::vec2 t = sp.uv[ref.texcoord == 1 ? 1 : 0];
    alpha *= textures[static_cast<std::size_t>(ref.index)]
                 .sample(ref.has_transform() ? ref.apply(t) : t)
                 .a;
  }
  return alpha;
}

std::size_t Scene::camera_index(const std::string& name) const {
  for (std::size_t i = 0; i < cameras.size(); ++i)
    if (cameras[i].name == name) return i;
  std::string available;
  for (const Camera& c : cameras) available += (available.empty() ? "'" : ", '") + c.name + "'";
  throw Error(source + ": no camera named '" + name +
              "' (available: " + (available.empty() ? std::string("none") : available) + ")");
}

std::vector<float> cumulative_distribution(const std::vector<double>& weights) {
  double total = 0.0;
  for (double w : weights) total += w;
  std::vector<float> cdf;
  cdf.reserve(weights.size());
  double running = 0.0;
  for (double w : weights) {
    running += w;
    cdf.push_back(static_cast<float>(running / total));
  }
  if (!cdf.empty()) cdf.back() = 1.0f;
  return cdf;
}

std::size_t Scene::sample_emitter(float u, float* probability) const {
  assert(!emitter_cdf.empty() && emitter_cdf.size() == emitters.size());
  if (emitter_cdf.empty()) {
    if (probability) *probability = 0.0f;
    return 0;
  }
  // First entry whose cumulative value exceeds u; entries with zero power are never chosen.
  auto it = std::upper_bound(emitter_cdf.begin(), emitter_cdf.end(), u);
  auto index = static_cast<std::size_t>(std::min<std::ptrdiff_t>(
      it - emitter_cdf.begin(), static_cast<std::ptrdiff_t>(emitter_cdf.size()) - 1));
  if (probability) *probability = emitter_cdf[index] - (index > 0 ? emitter_cdf[index - 1] : 0.0f);
  return index;
}

}  // namespace dofcache::scene
