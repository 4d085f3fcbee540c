#pragma once
// Small scenes built in code for render tests (independent of the glTF loader).
#include <array>
#include <cmath>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "dofcache/scene/scene.h"

namespace dofcache::testing {

// Adds the quad with these corners, in order, as two triangles (0 1 2, 0 2 3) with one normal.
inline void add_quad(scene::Scene& s, const std::array<glm::vec3, 4>& corners, glm::vec3 normal,
                     std::uint32_t material, std::uint32_t object) {
  auto base = static_cast<std::uint32_t>(s.mesh.positions.size());
  for (glm::vec3 p : corners) {
    s.mesh.positions.push_back(p);
    s.mesh.normals.push_back(normal);
    s.bounds.extend(p);
  }
  s.mesh.triangles.push_back({base, base + 1, base + 2});
  s.mesh.triangles.push_back({base, base + 2, base + 3});
  for (int i = 0; i < 2; ++i) {
    s.mesh.triangle_material.push_back(material);
    s.mesh.triangle_object.push_back(object);
  }
}

// Adds an axis-aligned quad in the plane z = `z` (world), facing +Z (towards a camera at +Z).
inline void add_quad_z(scene::Scene& s, float x0, float x1, float y0, float y1, float z,
                       std::uint32_t material, std::uint32_t object) {
  add_quad(s, {glm::vec3(x0, y0, z), glm::vec3(x1, y0, z), glm::vec3(x1, y1, z),
               glm::vec3(x0, y1, z)},
           {0.0f, 0.0f, 1.0f}, material, object);
}

// Adds a horizontal-ish light panel at height y0..y1, x in [-1, 1], plane z = `z`, facing -Z
// (away from a camera at the origin, towards the scene behind it).
inline void add_light_facing_away(scene::Scene& s, float y0, float y1, float z,
                                  std::uint32_t material, std::uint32_t object) {
  add_quad(s, {glm::vec3(-1, y0, z), glm::vec3(-1, y1, z), glm::vec3(1, y1, z),
               glm::vec3(1, y0, z)},
           {0.0f, 0.0f, -1.0f}, material, object);
}

inline scene::Material emissive_material(glm::vec3 radiance) {
  scene::Material m;
  m.base_color = glm::vec4(0.0f, 0.0f, 0.0f, 1.0f);
  m.metallic = 0.0f;
  m.emissive = radiance;
  return m;
}

inline scene::Material diffuse_material(glm::vec3 albedo) {
  scene::Material m;
  m.base_color = glm::vec4(albedo, 1.0f);
  m.metallic = 0.0f;
  m.roughness = 1.0f;
  return m;
}

// A camera at the origin looking down -Z (glTF convention) with vertical field of view `yfov`.
inline scene::Camera origin_camera(float yfov) {
  scene::Camera c;
  c.name = "test";
  c.yfov = yfov;
  return c;
}

// Registers every emissive triangle as an emitter (what the loader does).
inline void build_emitters(scene::Scene& s) {
  s.emitters.clear();
  s.emitter_cdf.clear();
  float total = 0.0f;
  for (std::uint32_t t = 0; t < s.mesh.triangles.size(); ++t) {
    glm::vec3 e = s.materials[s.mesh.triangle_material[t]].emissive;
    if (e.x + e.y + e.z <= 0.0f) continue;
    const glm::uvec3 tri = s.mesh.triangles[t];
    float area = 0.5f * glm::length(glm::cross(s.mesh.positions[tri.y] - s.mesh.positions[tri.x],
                                               s.mesh.positions[tri.z] - s.mesh.positions[tri.x]));
    s.emitters.push_back({t, area, e});
    total += area * (0.2126f * e.x + 0.7152f * e.y + 0.0722f * e.z);
    s.emitter_cdf.push_back(total);
  }
  for (float& c : s.emitter_cdf) c /= total;
}

// Adds a UV sphere (`rings` x 2 `rings` quads, smooth vertex normals, facing outwards).
inline void add_sphere(scene::Scene& s, glm::vec3 center, float radius, int rings,
                       std::uint32_t material, std::uint32_t object) {
  const auto base = static_cast<std::uint32_t>(s.mesh.positions.size());
  const int segments = 2 * rings;
  for (int i = 0; i <= rings; ++i)
    for (int j = 0; j <= segments; ++j) {
      const float theta = 3.14159265f * static_cast<float>(i) / rings;
      const float phi = 2.0f * 3.14159265f * static_cast<float>(j) / segments;
      const glm::vec3 n(std::sin(theta) * std::cos(phi), std::cos(theta),
                        std::sin(theta) * std::sin(phi));
      s.mesh.positions.push_back(center + radius * n);
      s.mesh.normals.push_back(n);
      s.bounds.extend(center + radius * n);
    }
  auto at = [&](int i, int j) { return base + static_cast<std::uint32_t>(i * (segments + 1) + j); };
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      // Counter-clockwise seen from outside; the quads at the poles degenerate to one triangle.
      if (i > 0) s.mesh.triangles.push_back({at(i, j), at(i, j + 1), at(i + 1, j)});
      if (i + 1 < rings) s.mesh.triangles.push_back({at(i, j + 1), at(i + 1, j + 1), at(i + 1, j)});
      const int added = (i > 0) + (i + 1 < rings);
      for (int k = 0; k < added; ++k) {
        s.mesh.triangle_material.push_back(material);
        s.mesh.triangle_object.push_back(object);
      }
    }
}

// Irradiance / (pi L) at the origin (normal +Z) from a parallel rectangle [x0, x1] x [y0, y1] at
// height h: the corner form factor F(a, b) = (1 / 2pi) [A / sqrt(1 + A^2) atan(B / sqrt(1 + A^2)) +
// B / sqrt(1 + B^2) atan(A / sqrt(1 + B^2))], A = a / h, B = b / h, is odd in a and b, so any
// rectangle is a signed sum of four corners.
inline double rectangle_form_factor(double x0, double x1, double y0, double y1, double h) {
  auto corner = [h](double a, double b) {
    double A = a / h, B = b / h, sa = std::sqrt(1 + A * A), sb = std::sqrt(1 + B * B);
    return (A / sa * std::atan(B / sa) + B / sb * std::atan(A / sb)) / (2 * 3.14159265358979323846);
  };
  return corner(x1, y1) - corner(x0, y1) - corner(x1, y0) + corner(x0, y0);
}

}  // namespace dofcache::testing
