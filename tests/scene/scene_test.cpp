// Scene's own logic (texture filtering and wrapping, surface points, materials, cameras, emitter
// sampling) on hand-built scenes, with expected values computed by hand.
#include "dofcache/scene/scene.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "dofcache/core/error.h"

namespace dofcache::scene {
namespace {

void expect_vec3(glm::vec3 a, glm::vec3 b, float tol = 1e-5f) {
  EXPECT_NEAR(a.x, b.x, tol);
  EXPECT_NEAR(a.y, b.y, tol);
  EXPECT_NEAR(a.z, b.z, tol);
}

// 2 x 1 texture: left texel 0, right texel 1 (all channels).
Texture two_texels(Wrap wrap, bool nearest) {
  Texture t;
  t.width = 2;
  t.height = 1;
  t.texels = {glm::vec4(0.0f), glm::vec4(1.0f)};
  t.wrap_s = t.wrap_t = wrap;
  t.nearest = nearest;
  return t;
}

TEST(Texture, BilinearBetweenTexelCentres) {
  Texture t = two_texels(Wrap::ClampToEdge, false);
  // Centres at u = 0.25 and 0.75; halfway (u = 0.5) is the average; beyond clamps.
  EXPECT_FLOAT_EQ(t.sample({0.25f, 0.5f}).r, 0.0f);
  EXPECT_FLOAT_EQ(t.sample({0.75f, 0.5f}).r, 1.0f);
  EXPECT_FLOAT_EQ(t.sample({0.5f, 0.5f}).r, 0.5f);
  EXPECT_FLOAT_EQ(t.sample({0.375f, 0.5f}).r, 0.25f);
  EXPECT_FLOAT_EQ(t.sample({0.95f, 0.5f}).r, 1.0f);
  // Repeat blends across the seam: u = 0 is halfway between texel 1 (wrapped) and texel 0.
  Texture r = two_texels(Wrap::Repeat, false);
  EXPECT_FLOAT_EQ(r.sample({0.0f, 0.5f}).r, 0.5f);
  EXPECT_FLOAT_EQ(r.sample({1.0f, 0.5f}).r, 0.5f);
  // Mirrored repeat at u = 0: texel -1 mirrors to texel 0, so no blending with texel 1.
  Texture m = two_texels(Wrap::MirroredRepeat, false);
  EXPECT_FLOAT_EQ(m.sample({0.0f, 0.5f}).r, 0.0f);
}

TEST(Texture, NearestWrapsAndSurvivesHugeOrNonFiniteCoordinates) {
  Texture t = two_texels(Wrap::Repeat, true);
  EXPECT_FLOAT_EQ(t.sample({0.49f, 0.0f}).r, 0.0f);
  EXPECT_FLOAT_EQ(t.sample({0.51f, 0.0f}).r, 1.0f);
  EXPECT_FLOAT_EQ(t.sample({-0.25f, 0.0f}).r, 1.0f);  // x = -1 -> texel 1
  EXPECT_FLOAT_EQ(t.sample({3.75f, 0.0f}).r, 1.0f);   // x = 7 -> texel 1
  glm::vec4 huge = t.sample({1e30f, -1e30f});
  EXPECT_TRUE(huge.r == 0.0f || huge.r == 1.0f);
  glm::vec4 nan = t.sample({std::nanf(""), INFINITY});
  EXPECT_TRUE(nan.r == 0.0f || nan.r == 1.0f);
  EXPECT_EQ(Texture{}.sample({0.5f, 0.5f}), glm::vec4(1.0f));  // empty texture is neutral
}

TEST(Texture, SrgbDecodedBeforeFiltering) {
  Texture t = two_texels(Wrap::ClampToEdge, false);
  t.texels = {glm::vec4(0.0f, 0.0f, 0.0f, 0.0f), glm::vec4(1.0f, 0.5f, 0.04f, 1.0f)};
  glm::vec4 right = t.sample_srgb({0.75f, 0.5f});
  EXPECT_FLOAT_EQ(right.r, 1.0f);
  EXPECT_NEAR(right.g, 0.2140411f, 1e-6);      // ((0.5 + 0.055) / 1.055)^2.4
  EXPECT_NEAR(right.b, 0.04f / 12.92f, 1e-7);  // linear segment
  EXPECT_FLOAT_EQ(right.a, 1.0f);              // alpha is not decoded
  EXPECT_NEAR(t.sample_srgb({0.5f, 0.5f}).g, 0.5f * 0.2140411f, 1e-6);
}

TEST(Bounds, ExtendCenterDiagonal) {
  Bounds b;
  EXPECT_FLOAT_EQ(b.diagonal(), 0.0f);  // empty
  b.extend({1, 2, 3});
  b.extend({-1, 0, 3});
  expect_vec3(b.center(), {0, 1, 3});
  EXPECT_FLOAT_EQ(b.diagonal(), std::sqrt(8.0f));
}

// Triangle (0,0,0), (2,0,0), (0,2,0) with distinct vertex normals and uvs.
Scene small_scene() {
  Scene s;
  s.mesh.positions = {{0, 0, 0}, {2, 0, 0}, {0, 2, 0}};
  s.mesh.normals = {{0, 0, 1}, {1, 0, 0}, {0, 1, 0}};
  s.mesh.uv0 = {{0, 0}, {1, 0}, {0, 1}};
  s.mesh.uv1 = {{0.5f, 0.5f}, {0.5f, 0.5f}, {0.5f, 0.5f}};
  s.mesh.triangles = {{0, 1, 2}};
  s.mesh.triangle_material = {0};
  s.mesh.triangle_object = {0};
  s.materials.resize(1);
  s.source = "small";
  return s;
}

TEST(Scene, SurfacePointFromEmbreeBarycentrics) {
  Scene s = small_scene();
  // p = (1-u-v) p0 + u p1 + v p2 with u = 0.25, v = 0.5: (0.5, 1, 0).
  SurfacePoint sp = s.surface_point(0, 0.25f, 0.5f);
  expect_vec3(sp.position, {0.5f, 1.0f, 0.0f});
  expect_vec3(sp.geometric_normal, {0, 0, 1});  // counter-clockwise seen from +Z
  // Interpolated normal 0.25 (0,0,1) + 0.25 (1,0,0) + 0.5 (0,1,0), normalised.
  expect_vec3(sp.shading_normal, glm::vec3(0.25f, 0.5f, 0.25f) / std::sqrt(0.375f));
  EXPECT_FLOAT_EQ(sp.uv[0].x, 0.25f);
  EXPECT_FLOAT_EQ(sp.uv[0].y, 0.5f);
  EXPECT_FLOAT_EQ(sp.uv[1].x, 0.5f);
  EXPECT_EQ(sp.triangle, 0u);
  EXPECT_EQ(sp.material, 0u);
}

TEST(Scene, MaterialAtMultipliesFactorsAndTextures) {
  Scene s = small_scene();
  Texture white_and_grey;  // 1 x 1, value (1, 0.5, 0.25, 1)
  white_and_grey.width = white_and_grey.height = 1;
  white_and_grey.texels = {glm::vec4(1.0f, 0.5f, 0.25f, 1.0f)};
  s.textures = {white_and_grey};
  Material& m = s.materials[0];
  m.base_color = glm::vec4(0.5f, 1.0f, 1.0f, 1.0f);
  m.base_color_texture = {0, 1};  // sRGB, TEXCOORD_1
  m.metallic = 0.8f;
  m.roughness = 0.6f;
  m.metallic_roughness_texture = {0, 0};  // linear: G = 0.5 roughness, B = 0.25 metallic
  m.emissive = glm::vec3(2.0f);
  MaterialPoint mp = s.material_at(s.surface_point(0, 0.3f, 0.3f));
  expect_vec3(mp.base_color, {0.5f, 0.2140411f, 0.0508761f});  // sRGB 0.25 -> 0.0508761
  EXPECT_FLOAT_EQ(mp.roughness, 0.3f);
  EXPECT_FLOAT_EQ(mp.metallic, 0.2f);
  expect_vec3(mp.emission, {2, 2, 2});
  expect_vec3(mp.diffuse_albedo(), mp.base_color * 0.8f);
}

TEST(Scene, CameraIndexByNameOrErrorListingNames) {
  Scene s = small_scene();
  s.cameras.resize(2);
  s.cameras[0].name = "main";
  s.cameras[1].name = "closeup";
  EXPECT_EQ(s.camera_index("closeup"), 1u);
  try {
    s.camera_index("wide");
    FAIL();
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "small: no camera named 'wide' (available: 'main', 'closeup')");
  }
}

TEST(Scene, SampleEmitterBinarySearch) {
  Scene s = small_scene();
  s.emitters.resize(4);
  s.emitter_cdf = {0.1f, 0.1f, 0.6f, 1.0f};  // powers 0.1, 0, 0.5, 0.4
  float p = 0.0f;
  EXPECT_EQ(s.sample_emitter(0.0f, &p), 0u);
  EXPECT_FLOAT_EQ(p, 0.1f);
  EXPECT_EQ(s.sample_emitter(0.1f, &p), 2u);  // the zero-power emitter is never chosen
  EXPECT_FLOAT_EQ(p, 0.5f);
  EXPECT_EQ(s.sample_emitter(0.59f, &p), 2u);
  EXPECT_EQ(s.sample_emitter(0.99999994f, &p), 3u);
  EXPECT_NEAR(p, 0.4f, 1e-6);
  EXPECT_EQ(s.sample_emitter(0.7f, nullptr), 3u);
}

}  // namespace
}  // namespace dofcache::scene
