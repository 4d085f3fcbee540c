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

}  // namespace

std::vector<glm::vec4> generate_tangents(const std::vector<glm::vec3>& positions,
                                         const std::vector<glm::vec3>& normals,
                                         const std::vector<glm::vec2>& uvs,
                                         const std::vector<glm::uvec3>& triangles,
                                         std::size_t first_vertex, std::size_t first_triangle) {
  const std::size_t n = positions.size() - first_vertex;
  const std::size_t triangle_count = triangles.size() - first_triangle;
  // Each triangle's corner contributions (the costly part: three acos) in parallel, then summed
  // at the vertices in triangle order by one thread, so the sums, and the tangents, are the same
  // bits for any number of threads.
  struct Corners {
    glm::vec3 tangent[3], bitangent[3];
    bool uv_area = false;
  };
  std::vector<Corners> corners(triangle_count);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, triangle_count, 4096),
                    [&](const tbb::blocked_range<std::size_t>& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      Corners& out = corners[i];
      const glm::uvec3 tri = triangles[first_triangle + i];
      const std::uint32_t v[3] = {tri.x, tri.y, tri.z};
      const glm::vec3 e1 = positions[v[1]] - positions[v[0]];
      const glm::vec3 e2 = positions[v[2]] - positions[v[0]];
      const glm::vec2 d1 = uvs[v[1]] - uvs[v[0]], d2 = uvs[v[2]] - uvs[v[0]];
      const float det = d1.x * d2.y - d2.x * d1.y;
      if (!(std::abs(det) > 1e-20f) || !std::isfinite(det)) {  // no UV area: adds nothing
        out = Corners{};
        continue;
      }
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
    }
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
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096),
                    [&](const tbb::blocked_range<std::size_t>& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      const glm::vec3 nrm = normals[first_vertex + i];
      glm::vec3 t = tangent[i] - glm::dot(tangent[i], nrm) * nrm;  // Gram-Schmidt
      float len = glm::length(t);
      if (!(len > 1e-12f) || !std::isfinite(len)) {
        // Any direction perpendicular to the normal: the axis least aligned with it, projected.
        glm::vec3 axis = std::abs(nrm.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
        t = glm::normalize(axis - glm::dot(axis, nrm) * nrm);
        out[i] = glm::vec4(t, 1.0f);
        continue;
      }
      t /= len;
      const float w = glm::dot(glm::cross(nrm, t), bitangent[i]) < 0.0f ? -1.0f : 1.0f;
      out[i] = glm::vec4(t, w);
    }
  });
  return out;
}

}  // namespace dofcache::scene
