#include "dofcache/scene/tangents.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <glm/geometric.hpp>

namespace dofcache::scene {
namespace {

float corner_angle(glm::vec3 a, glm::vec3 b) {
  float la = glm::length(a), lb = glm::length(b);
  if (!(la > 0.0f) || !(lb > 0.0f)) return 0.0f;
  return std::acos(std::clamp(glm::dot(a, b) / (la * lb), -1.0f, 1.0f));
}

// One triangle's tangent and bitangent (the directions of increasing u and v) weighted by the
// angle at each corner; zero where the texture coordinates have no area.
struct Corners {
  glm::vec3 tangent[3], bitangent[3];
  bool uv_area = false;
};

Corners corner_contributions(const std::vector<glm::vec3>& positions,
                             const std::vector<glm::vec2>& uvs, glm::uvec3 tri) {
  Corners out;
  const std::uint32_t v[3] = {tri.x, tri.y, tri.z};
  const glm::vec3 e1 = positions[v[1]] - positions[v[0]], e2 = positions[v[2]] - positions[v[0]];
  const glm::vec2 d1 = uvs[v[1]] - uvs[v[0]], d2 = uvs[v[2]] - uvs[v[0]];
  const float det = d1.x * d2.y - d2.x * d1.y;
  if (!(std::abs(det) > 1e-20f) || !std::isfinite(det)) return out;  // no UV area
  // Solve e1 = d1.x T + d1.y B, e2 = d2.x T + d2.y B for T (dp/du) and B (dp/dv).
  const glm::vec3 tu = (d2.y * e1 - d1.y * e2) / det;
  const glm::vec3 tv = (d1.x * e2 - d2.x * e1) / det;
  for (int c = 0; c < 3; ++c) {
    const glm::vec3 p = positions[v[c]];
    const float w = corner_angle(positions[v[(c + 1) % 3]] - p, positions[v[(c + 2) % 3]] - p);
    out.tangent[c] = w * tu;
    out.bitangent[c] = w * tv;
  }
  out.uv_area = true;
  return out;
}

// The accumulated tangent made orthogonal to the normal (Gram-Schmidt), with the handedness of
// the accumulated bitangent; any perpendicular direction where nothing was accumulated.
glm::vec4 vertex_tangent(glm::vec3 nrm, glm::vec3 tangent, glm::vec3 bitangent) {
  glm::vec3 t = tangent - glm::dot(tangent, nrm) * nrm;
  const float len = glm::length(t);
  if (!(len > 1e-12f) || !std::isfinite(len)) {
    // The axis least aligned with the normal, projected.
    const glm::vec3 axis = std::abs(nrm.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
    return glm::vec4(glm::normalize(axis - glm::dot(axis, nrm) * nrm), 1.0f);
  }
  t /= len;
  return glm::vec4(t, glm::dot(glm::cross(nrm, t), bitangent) < 0.0f ? -1.0f : 1.0f);
}

template <class Body>
void parallel_indices(std::size_t count, const Body& body) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, 4096),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      for (std::size_t i = range.begin(); i != range.end(); ++i) body(i);
                    });
}

}  // namespace

std::vector<glm::vec4> generate_tangents(const std::vector<glm::vec3>& positions,
                                         const std::vector<glm::vec3>& normals,
                                         const std::vector<glm::vec2>& uvs,
                                         const std::vector<glm::uvec3>& triangles,
                                         std::size_t first_vertex, std::size_t first_triangle) {
  const std::size_t n = positions.size() - first_vertex;
  const std::size_t triangle_count = triangles.size() - first_triangle;
  // The corner contributions (the costly part: three acos a triangle) in parallel, then summed at
  // the vertices in triangle order by one thread, so the sums, and the tangents, are the same
  // bits for any number of threads.
  std::vector<Corners> corners(triangle_count);
  parallel_indices(triangle_count, [&](std::size_t i) {
    corners[i] = corner_contributions(positions, uvs, triangles[first_triangle + i]);
  });
  std::vector<glm::vec3> tangent(n, glm::vec3(0.0f)), bitangent(n, glm::vec3(0.0f));
  for (std::size_t i = 0; i < triangle_count; ++i) {
    if (!corners[i].uv_area) continue;
    const glm::uvec3 tri = triangles[first_triangle + i];
    const std::uint32_t v[3] = {tri.x, tri.y, tri.z};
    for (int c = 0; c < 3; ++c) {
      tangent[v[c] - first_vertex] += corners[i].tangent[c];
      bitangent[v[c] - first_vertex] += corners[i].bitangent[c];
    }
  }
  std::vector<glm::vec4> out(n);
  parallel_indices(n, [&](std::size_t i) {
    out[i] = vertex_tangent(normals[first_vertex + i], tangent[i], bitangent[i]);
  });
  return out;
}

}  // namespace dofcache::scene
