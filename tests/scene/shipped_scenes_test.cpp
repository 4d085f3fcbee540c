// Every scene in scenes/ loads with what the renderer needs, and the built-in default is exactly
// scenes/cornell_box.gltf.
#include <gtest/gtest.h>

#include <string>

#include <glm/geometric.hpp>

#include "dofcache/scene/accel.h"
#include "dofcache/scene/default_scene.h"
#include "dofcache/scene/gltf_loader.h"

namespace dofcache::scene {
namespace {

std::string scene_path(const std::string& file) {
  return std::string(DOFCACHE_SOURCE_DIR) + "/scenes/" + file;
}

struct Shipped {
  const char* file;
  std::size_t materials;
  std::size_t textures;
  std::size_t lights;
};

class ShippedScene : public ::testing::TestWithParam<Shipped> {};

TEST_P(ShippedScene, LoadsWithCameraLensEmittersAndMaterials) {
  const Shipped& expected = GetParam();
  Scene s = load_gltf(scene_path(expected.file));
  EXPECT_TRUE(s.warnings.empty()) << s.warnings.front();
  EXPECT_GT(s.mesh.triangles.size(), 100u);
  EXPECT_LT(s.mesh.triangles.size(), 30000u);
  EXPECT_EQ(s.mesh.triangle_material.size(), s.mesh.triangles.size());
  EXPECT_EQ(s.mesh.normals.size(), s.mesh.positions.size());
  EXPECT_GE(s.emitters.size(), 1u);
  EXPECT_FLOAT_EQ(s.emitter_cdf.back(), 1.0f);
  EXPECT_EQ(s.materials.size(), expected.materials);
  EXPECT_EQ(s.textures.size(), expected.textures);
  EXPECT_EQ(s.lights.size(), expected.lights);

  ASSERT_EQ(s.cameras.size(), 1u);
  const Camera& c = s.cameras[0];
  EXPECT_FALSE(c.synthesized);
  ASSERT_TRUE(c.lens.focal_length && c.lens.fstop && c.lens.focus_distance);
  EXPECT_DOUBLE_EQ(*c.lens.focal_length, 0.1);  // tabletop scenes, 100 mm lens
  EXPECT_GT(*c.lens.focus_distance, 0.3);
  EXPECT_LT(*c.lens.focus_distance, 2.0);
  ASSERT_TRUE(c.aspect_ratio.has_value());

  // The focus distance lands on geometry: a ray along the view axis finds something within the
  // scene, and the scene lies in front of the camera.
  Accel accel(s);
  Ray ray;
  ray.origin = glm::vec3(c.camera_to_world[3]);
  ray.direction = -glm::vec3(c.camera_to_world[2]);
  EXPECT_TRUE(accel.intersect(ray).valid());
}

INSTANTIATE_TEST_SUITE_P(Scenes, ShippedScene,
                         ::testing::Values(Shipped{"cornell_box.gltf", 5, 0, 0},
                                           Shipped{"color_bars.gltf", 11, 0, 0},
                                           Shipped{"color_spheres.gltf", 10, 0, 1},
                                           Shipped{"glossy_closeup.glb", 9, 2, 0}),
                         [](const auto& info) {
                           std::string name = info.param.file;
                           return name.substr(0, name.find('.'));
                         });

TEST(DefaultScene, IsTheCornellBoxFile) {
  EXPECT_STREQ(default_scene_name(), "cornell_box");
  Scene built_in = load_default_scene();
  Scene file = load_gltf(scene_path("cornell_box.gltf"));
  EXPECT_EQ(built_in.source, "cornell_box (built in)");
  EXPECT_EQ(built_in.content_hash, file.content_hash);
  EXPECT_EQ(built_in.mesh.triangles.size(), file.mesh.triangles.size());
  EXPECT_EQ(built_in.cameras[0].lens.fstop, file.cameras[0].lens.fstop);
  Scene from_memory = load_gltf_from_memory(default_scene_gltf(), "again");
  EXPECT_EQ(from_memory.content_hash, file.content_hash);
}

TEST(ColorBars, HiddenBallIsBehindTheYellowBarFromThePinhole) {
  Scene s = load_gltf(scene_path("color_bars.gltf"));
  const Camera& c = s.cameras[0];
  // The glowing ball's centroid, from its emitter triangles' vertices (material "glow").
  glm::vec3 sum(0.0f);
  int count = 0;
  for (std::size_t t = 0; t < s.mesh.triangles.size(); ++t) {
    if (s.materials[s.mesh.triangle_material[t]].name != "glow") continue;
    sum += s.mesh.positions[s.mesh.triangles[t].x];
    ++count;
  }
  ASSERT_GT(count, 0);
  Accel accel(s);
  Ray ray;
  ray.origin = glm::vec3(c.camera_to_world[3]);
  ray.direction = sum / static_cast<float>(count) - ray.origin;
  Hit hit = accel.intersect(ray);
  ASSERT_TRUE(hit.valid());
  EXPECT_EQ(s.materials[s.mesh.triangle_material[hit.triangle]].name, "yellow");
}

TEST(GlossyCloseup, BinaryGltfWithPngTextures) {
  Scene s = load_gltf(scene_path("glossy_closeup.glb"));
  bool glazed = false, mirror = false;
  for (const Material& m : s.materials) {
    if (m.base_color_texture.index >= 0 && m.metallic_roughness_texture.index >= 0) glazed = true;
    if (m.metallic == 1.0f && m.roughness <= 0.06f) mirror = true;
  }
  EXPECT_TRUE(glazed);
  EXPECT_TRUE(mirror);
  ASSERT_EQ(s.textures.size(), 2u);
  EXPECT_EQ(s.textures[0].width, 128);
  // The roughness texture holds 0.2 and 0.35 in G, metallic 0 in B.
  glm::vec4 band = s.textures[1].sample({0.5f, 0.01f});
  EXPECT_NEAR(band.g, 0.2f, 0.003f);
  EXPECT_FLOAT_EQ(band.b, 0.0f);
  EXPECT_FALSE(s.mesh.uv0.empty());
}

}  // namespace
}  // namespace dofcache::scene
