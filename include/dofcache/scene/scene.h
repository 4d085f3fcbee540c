#pragma once
// The renderer's view of a scene: one flattened world-space triangle mesh, glTF metallic-roughness
// materials, lights and cameras. Loaders (glTF) produce it; the Embree accelerator and shaders
// read it. Immutable after loading.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "dofcache/lens/aperture.h"

namespace dofcache::scene {

enum class Wrap { Repeat, ClampToEdge, MirroredRepeat };

struct Texture {
  int width = 0, height = 0;
  std::vector<glm::vec4> texels;  // as stored (not colour-managed); row 0 is the top (v = 0)
  Wrap wrap_s = Wrap::Repeat, wrap_t = Wrap::Repeat;
  bool nearest = false;           // magFilter NEAREST; otherwise bilinear
  // Filtered texel value at uv (glTF convention: (0,0) is the top-left corner of the image).
  glm::vec4 sample(glm::vec2 uv) const;
  // The same for sRGB-encoded colour: texels are decoded to linear before filtering (alpha is
  // linear already). An empty texture samples as 1.
  glm::vec4 sample_srgb(glm::vec2 uv) const;
};

struct TextureRef {
  int index = -1;    // into Scene::textures, -1 for none
  int texcoord = 0;  // TEXCOORD_n set (0 or 1), after KHR_texture_transform's override
  // KHR_texture_transform: uv' = offset + R(rotation) (scale * uv), applied before sampling.
  glm::vec2 offset{0.0f}, scale{1.0f};
  float rotation = 0.0f;  // radians, counter-clockwise in UV space (v down), see apply()
  bool has_transform() const {
    return offset != glm::vec2(0.0f) || scale != glm::vec2(1.0f) || rotation != 0.0f;
  }
  glm::vec2 apply(glm::vec2 uv) const;
};

enum class AlphaMode { Opaque, Mask, Blend };

struct Material {
  std::string name;
  glm::vec4 base_color{1.0f};          // linear
  TextureRef base_color_texture;       // sRGB-encoded texels
  float metallic = 1.0f, roughness = 1.0f;
  TextureRef metallic_roughness_texture;  // B = metallic, G = roughness (linear)
  glm::vec3 emissive{0.0f};            // emissiveFactor * KHR_materials_emissive_strength
  TextureRef emissive_texture;         // sRGB
  TextureRef normal_texture;           // tangent-space normals (linear), needs Mesh::tangents
  float normal_scale = 1.0f;           // scales the map's x and y
  // One-sided surfaces are invisible from behind (glTF culls their back faces): see accel.h.
  bool double_sided = false;
  // MASK: cut out where alpha < alpha_cutoff; BLEND: stochastic, seen with probability alpha.
  // Alpha = base_color.a * base colour texture alpha * COLOR_0 alpha (Scene::alpha_at).
  AlphaMode alpha_mode = AlphaMode::Opaque;
  float alpha_cutoff = 0.5f;
};

// A material evaluated at one surface point (textures applied).
struct MaterialPoint {
  glm::vec3 base_color{1.0f};  // linear
  float metallic = 0.0f;
  float roughness = 1.0f;
  glm::vec3 emission{0.0f};    // emitted radiance
  glm::vec3 normal{0.0f, 0.0f, 1.0f};  // shading normal with the normal texture applied (unit)
  // Lambertian albedo of the glTF BRDF's diffuse lobe: base_color * (1 - metallic).
  glm::vec3 diffuse_albedo() const { return base_color * (1.0f - metallic); }
};

struct SurfacePoint {
  glm::vec3 position{0.0f};
  glm::vec3 geometric_normal{0.0f, 0.0f, 1.0f};  // unit, from the winding order
  glm::vec3 shading_normal{0.0f, 0.0f, 1.0f};    // unit, interpolated vertex normal (or geometric)
  glm::vec2 uv[2]{};
  glm::vec4 color{1.0f};    // interpolated COLOR_0 (1 without it)
  glm::vec4 tangent{0.0f};  // interpolated TANGENT (xyz world space, w handedness); 0: none
  std::uint32_t triangle = 0;
  std::uint32_t material = 0;
};

struct Mesh {
  std::vector<glm::vec3> positions;  // world space
  std::vector<glm::vec3> normals;    // world space, one per position (unit)
  std::vector<glm::vec2> uv0, uv1;   // one per position, or empty
  std::vector<glm::vec4> colors;     // COLOR_0 (linear RGBA), one per position, or empty
  // World-space tangents (xyz unit, w = +-1 handedness: bitangent = w cross(normal, tangent)),
  // one per position, or empty; zero where a primitive has no normal texture.
  std::vector<glm::vec4> tangents;
  std::vector<glm::uvec3> triangles;
  std::vector<std::uint32_t> triangle_material;  // index into Scene::materials
  std::vector<std::uint32_t> triangle_object;    // object id: index of the glTF node instance
};

struct PunctualLight {  // KHR_lights_punctual, in world space
  enum class Type { Directional, Point, Spot };
  Type type = Type::Point;
  glm::vec3 position{0.0f};
  glm::vec3 direction{0.0f, 0.0f, -1.0f};  // direction the light travels (unit)
  glm::vec3 intensity{1.0f};               // colour * intensity (W/sr-like for point/spot, lux for directional)
  float range = 0.0f;                       // 0: infinite
  float inner_cone = 0.0f, outer_cone = 0.78539816f;
};

// Normalised running sums of non-negative `weights` with a positive total, the last exactly 1: the
// table Scene::sample_emitter searches (and LightSampler per light).
std::vector<float> cumulative_distribution(const std::vector<double>& weights);

// Rec. 709 luminance of a linear RGB colour: the power weight of emitters.
inline float luminance(glm::vec3 c) { return 0.2126f * c.r + 0.7152f * c.g + 0.0722f * c.b; }

struct Emitter {  // one emissive triangle, an area light
  std::uint32_t triangle = 0;
  float area = 0.0f;
  glm::vec3 radiance{0.0f};  // mean emitted radiance over the triangle
};

// Depth-of-field settings carried in the camera node's `extras.lens` (see docs/scenes.md), metres.
struct LensExtras {
  std::optional<double> focal_length, fstop, focus_distance;
  lens::ApertureChoices aperture;  // aperture_blades, aperture_rotation, ... (lens/aperture.h)
};

struct Camera {
  std::string name;
  glm::mat4 camera_to_world{1.0f};  // glTF convention: looks down -Z, +Y up, no scale
  float yfov = 0.8f;                // radians
  std::optional<float> aspect_ratio;
  float znear = 0.01f;
  LensExtras lens;
  int node = -1;                    // glTF node carrying the camera, -1 if synthesised
  bool synthesized = false;         // true if the scene had no camera and one was made to frame it
};

struct Bounds {
  glm::vec3 lower{1e30f}, upper{-1e30f};
  void extend(glm::vec3 p);
  glm::vec3 center() const { return 0.5f * (lower + upper); }
  float diagonal() const;
};

struct Scene {
  Mesh mesh;
  std::vector<Material> materials;
  std::vector<Texture> textures;
  std::vector<PunctualLight> lights;
  std::vector<Emitter> emitters;
  std::vector<float> emitter_cdf;  // cumulative, normalised, by power (area * luminance)
  std::vector<Camera> cameras;     // never empty after loading
  Bounds bounds;
  std::string source;              // path it was loaded from, or a name for built-in scenes
  std::uint64_t content_hash = 0;  // hash of geometry, materials and lights: a scene's identity
  std::vector<std::string> warnings;  // non-fatal loading notes (skipped points/lines, ...)

  SurfacePoint surface_point(std::uint32_t triangle, float u, float v) const;  // Embree barycentrics
  MaterialPoint material_at(const SurfacePoint& sp) const;
  // Coverage of a triangle's material at Embree barycentrics (u, v): base colour alpha times
  // its texture's alpha times COLOR_0's (1 for OPAQUE materials).
  float alpha_at(std::uint32_t triangle, float u, float v) const;
  // Index into `cameras` by name; throws dofcache::Error listing the available names.
  std::size_t camera_index(const std::string& name) const;
  // The camera called `name`, or the first camera if `name` is empty (throws like camera_index).
  const Camera& camera_or_first(const std::string& name) const {
    return cameras[name.empty() ? 0 : camera_index(name)];
  }
  // Picks an emitter proportionally to power from u in [0,1); returns index and its probability.
  std::size_t sample_emitter(float u, float* probability) const;
};

}  // namespace dofcache::scene
