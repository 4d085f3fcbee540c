// Generated tangents follow the normal texture's KHR_texture_transform: the map's x axis runs
// along the u it is sampled with, the transformed one. The extension's matrix (its spec):
// u' = cos(r) u + sin(r) v, v' = -sin(r) u + cos(r) v, after scaling.
#include <gtest/gtest.h>

#include <string>

#include <glm/geometric.hpp>

#include "dofcache/scene/gltf_loader.h"
#include "scene/gltf_builder.h"

namespace dofcache::scene {
namespace {

using test::Gltf;

// The unit triangle in z = 0 with normal +z and u along +x, v along +y, normal-mapped with a
// 1x1 texel (218, 128, 218): c = (0.710, 0.004, 0.710) in tangent space.
Scene load_mapped(const std::string& transform) {
  Gltf g;
  const int pos = g.add_floats({0, 0, 0, 1, 0, 0, 0, 1, 0}, "VEC3");
  const int nrm = g.add_floats({0, 0, 1, 0, 0, 1, 0, 0, 1}, "VEC3");
  const int uv = g.add_floats({0, 0, 1, 0, 0, 1}, "VEC2");
  return load_gltf_from_memory(
      g.json("\"extensionsUsed\":[\"KHR_texture_transform\"],\"nodes\":[{\"mesh\":0}],"
             "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":" +
             std::to_string(pos) + ",\"NORMAL\":" + std::to_string(nrm) +
             ",\"TEXCOORD_0\":" + std::to_string(uv) +
             "},\"material\":0}]}],\"materials\":[{\"normalTexture\":{\"index\":0,"
             "\"extensions\":{\"KHR_texture_transform\":" + transform +
             "}}}],\"images\":[{\"uri\":\"data:image/bmp;base64," +
             test::base64(test::bmp(1, 1, {218, 128, 218})) +
             "\"}],\"textures\":[{\"source\":0}]"),
      "transformed_normal_map.gltf");
}

const glm::vec3 kMapped(218.0f / 255.0f * 2.0f - 1.0f, 128.0f / 255.0f * 2.0f - 1.0f,
                        218.0f / 255.0f * 2.0f - 1.0f);

void expect_near(glm::vec3 a, glm::vec3 b) {
  EXPECT_NEAR(a.x, b.x, 1e-4f) << "x";
  EXPECT_NEAR(a.y, b.y, 1e-4f) << "y";
  EXPECT_NEAR(a.z, b.z, 1e-4f) << "z";
}

TEST(TangentTransform, RotatedNormalTextureTurnsTheGeneratedTangents) {
  // Rotation pi/2: u' = v, v' = -u. u' grows along +y: tangent (0,1,0); v' grows along -x,
  // which is cross(n, t) = cross(z, y): w = +1. n' = normalize(c.x t + c.y (-x) + c.z z).
  Scene s = load_mapped("{\"rotation\":1.5707963}");
  ASSERT_EQ(s.mesh.tangents.size(), 3u);
  for (const glm::vec4& t : s.mesh.tangents) {
    expect_near(glm::vec3(t), glm::vec3(0, 1, 0));
    EXPECT_EQ(t.w, 1.0f);
  }
  expect_near(s.material_at(s.surface_point(0, 0.2f, 0.3f)).normal,
              glm::normalize(glm::vec3(-kMapped.y, kMapped.x, kMapped.z)));
}

TEST(TangentTransform, MirroringScaleFlipsTheHandedness) {
  // Scale (1, -1): u' = u (tangent +x), v' = -v grows along -y, against cross(z, x) = +y:
  // w = -1. n' = normalize(c.x x - c.y y + c.z z).
  Scene s = load_mapped("{\"scale\":[1,-1]}");
  ASSERT_EQ(s.mesh.tangents.size(), 3u);
  for (const glm::vec4& t : s.mesh.tangents) {
    expect_near(glm::vec3(t), glm::vec3(1, 0, 0));
    EXPECT_EQ(t.w, -1.0f);
  }
  expect_near(s.material_at(s.surface_point(0, 0.2f, 0.3f)).normal,
              glm::normalize(glm::vec3(kMapped.x, -kMapped.y, kMapped.z)));
}

}  // namespace
}  // namespace dofcache::scene
