#pragma once
// Per-vertex tangents from texture coordinates, for normal textures on meshes whose file gives no
// TANGENT attribute (glTF 3.7.2.1 asks for MikkTSpace there).
#include <cstddef>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

namespace dofcache::scene {

// Tangents of vertices [first_vertex, positions.size()) from triangles [first_triangle, end) of
// `triangles` (which index those vertices), in the manner of MikkTSpace: each triangle's tangent
// and bitangent (the directions of increasing u and v, from its edges and texture coordinates)
// are accumulated at its corners, weighted by the corner angle; the sum is made orthogonal to
// the vertex normal (Gram-Schmidt) and the handedness w = +-1 is the sign of the accumulated
// bitangent against cross(normal, tangent). It is not MikkTSpace itself: vertices are not split
// where tangent frames disagree, and degenerate texture mappings get an arbitrary frame rather
// than MikkTSpace's. Triangles whose UVs have no area add nothing; a vertex left without a
// tangent gets one perpendicular to its normal (w = 1), so the frame is always valid.
std::vector<glm::vec4> generate_tangents(const std::vector<glm::vec3>& positions,
                                         const std::vector<glm::vec3>& normals,
                                         const std::vector<glm::vec2>& uvs,
                                         const std::vector<glm::uvec3>& triangles,
                                         std::size_t first_vertex, std::size_t first_triangle);

}  // namespace dofcache::scene
