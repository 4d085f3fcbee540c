// The glTF loader against small hand-built files (written by the test into a temporary folder),
// with expected values computed by hand in the comments; then every kind of bad input.
#include "dofcache/scene/gltf_loader.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include <unistd.h>
#include <glm/geometric.hpp>

#include "dofcache/core/error.h"
#include "scene/gltf_builder.h"

namespace dofcache::scene {
namespace {

namespace fs = std::filesystem;
using test::base64;
using test::expect_error;
using test::bmp;
using test::Gltf;

class GltfLoaderTest : public ::testing::Test {
 protected:
  static fs::path dir() {
    static fs::path d = [] {
      fs::path p =
          fs::temp_directory_path() / ("dofcache_gltf_loader_test_" + std::to_string(::getpid()));
      fs::create_directories(p);
      return p;
    }();
    return d;
  }
  static std::string write(const std::string& name, const std::string& text) {
    fs::path p = dir() / name;
    std::ofstream(p, std::ios::binary) << text;
    return p.string();
  }
  static Scene load(const std::string& name, const std::string& text, LoadOptions options = {}) {
    return load_gltf(write(name, text), options);
  }
  static void TearDownTestSuite() { fs::remove_all(dir()); }
};

// One primitive with POSITION (and optional extras), material 0 if `material`.
std::string triangle_mesh(int position, const std::string& more_attributes = "", int indices = -1,
                          int material = -1, const std::string& mode = "") {
  return "{\"primitives\":[{\"attributes\":{\"POSITION\":" + std::to_string(position) +
         more_attributes + "}" + (indices >= 0 ? ",\"indices\":" + std::to_string(indices) : "") +
         (material >= 0 ? ",\"material\":" + std::to_string(material) : "") + mode + "}]}";
}

const std::vector<float> kTriangle = {0, 0, 0, 1, 0, 0, 0, 1, 0};

void expect_vec3(glm::vec3 actual, glm::vec3 expected, float tol = 1e-5f) {
  EXPECT_NEAR(actual.x, expected.x, tol);
  EXPECT_NEAR(actual.y, expected.y, tol);
  EXPECT_NEAR(actual.z, expected.z, tol);
}

// ---------------------------------------------------------------------------------------------
// Transforms

TEST_F(GltfLoaderTest, NodeTrsGivesHandComputedWorldPositions) {
  Gltf g;
  int pos = g.add_floats(kTriangle, "VEC3");
  // T = (1,2,3), R = 90 degrees about +Z (x, y, z, w) = (0, 0, sin 45, cos 45), S = 2.
  // p1 = (1,0,0): scale (2,0,0), rotate (0,2,0), translate (1,4,3).
  // p2 = (0,1,0): scale (0,2,0), rotate (-2,0,0), translate (-1,2,3).
  const double h = std::sqrt(0.5);
  Scene s =
      load("trs.gltf", g.json("\"nodes\":[{\"mesh\":0,\"translation\":[1,2,3],\"rotation\":[0,0," +
                              std::to_string(h) + "," + std::to_string(h) +
                              "],\"scale\":[2,2,2]}],\"meshes\":[" + triangle_mesh(pos) + "]"));
  ASSERT_EQ(s.mesh.triangles.size(), 1u);
  const glm::uvec3 t = s.mesh.triangles[0];
  expect_vec3(s.mesh.positions[t.x], {1, 2, 3});
  expect_vec3(s.mesh.positions[t.y], {1, 4, 3});
  expect_vec3(s.mesh.positions[t.z], {-1, 2, 3});
  EXPECT_EQ(s.mesh.triangle_object[0], 0u);
}

TEST_F(GltfLoaderTest, MatrixParentAndTrsChildCompose) {
  Gltf g;
  int pos = g.add_floats(kTriangle, "VEC3");
  // Parent: column-major matrix = rotation 90 degrees about +Y (x -> -z, z -> x), then
  // translation (0,0,-5). Child: scale (3,1,1).
  // p1 = (1,0,0): child (3,0,0), rotate (0,0,-3), translate (0,0,-8).
  // p2 = (0,1,0): child (0,1,0), rotate (0,1,0), translate (0,1,-5).
  Scene s = load("matrix.gltf",
                 g.json("\"scene\":0,\"scenes\":[{\"nodes\":[0]}],\"nodes\":["
                        "{\"matrix\":[0,0,-1,0, 0,1,0,0, 1,0,0,0, 0,0,-5,1],\"children\":[1]},"
                        "{\"mesh\":0,\"scale\":[3,1,1]}],\"meshes\":[" +
                        triangle_mesh(pos) + "]"));
  ASSERT_EQ(s.mesh.triangles.size(), 1u);
  const glm::uvec3 t = s.mesh.triangles[0];
  expect_vec3(s.mesh.positions[t.x], {0, 0, -5});
  expect_vec3(s.mesh.positions[t.y], {0, 0, -8});
  expect_vec3(s.mesh.positions[t.z], {0, 1, -5});
  EXPECT_EQ(s.mesh.triangle_object[0], 1u);  // the node carrying the mesh
}

// ---------------------------------------------------------------------------------------------
// Geometry

std::vector<glm::vec3> corners(const Scene& s) {
  std::vector<glm::vec3> out;
  for (const glm::uvec3& t : s.mesh.triangles)
    for (unsigned i : {t.x, t.y, t.z}) out.push_back(s.mesh.positions[i]);
  return out;
}

TEST_F(GltfLoaderTest, IndexedAndNonIndexedGiveIdenticalTriangles) {
  // A unit quad as two triangles: (0,1,2), (0,2,3).
  const std::vector<float> quad = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
  const std::vector<float> unrolled = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 0, 0, 1, 1, 0, 0, 1, 0};
  std::vector<std::vector<glm::vec3>> results;
  for (int variant = 0; variant < 4; ++variant) {
    Gltf g;
    int pos = g.add_floats(variant == 3 ? unrolled : quad, "VEC3");
    int idx = variant == 0   ? g.add_u8({0, 1, 2, 0, 2, 3})
              : variant == 1 ? g.add_u16({0, 1, 2, 0, 2, 3})
              : variant == 2 ? g.add_u32({0, 1, 2, 0, 2, 3})
                             : -1;
    Scene s =
        load("indexed" + std::to_string(variant) + ".gltf",
             g.json("\"nodes\":[{\"mesh\":0}],\"meshes\":[" + triangle_mesh(pos, "", idx) + "]"));
    ASSERT_EQ(s.mesh.triangles.size(), 2u) << variant;
    results.push_back(corners(s));
  }
  for (int variant = 1; variant < 4; ++variant) {
    ASSERT_EQ(results[variant].size(), results[0].size());
    for (std::size_t i = 0; i < results[0].size(); ++i)
      expect_vec3(results[variant][i], results[0][i], 0.0f);
  }
}

TEST_F(GltfLoaderTest, GeometricNormalsWhenNormalAbsent) {
  Gltf g;
  // Counter-clockwise seen from +Y: cross((0,0,1), (1,0,0)) = (0,1,0).
  int pos = g.add_floats({0, 0, 0, 0, 0, 1, 1, 0, 0}, "VEC3");
  Scene s =
      load("flat.gltf", g.json("\"nodes\":[{\"mesh\":0}],\"meshes\":[" + triangle_mesh(pos) + "]"));
  ASSERT_EQ(s.mesh.normals.size(), s.mesh.positions.size());
  for (glm::vec3 n : s.mesh.normals) expect_vec3(n, {0, 1, 0});
  SurfacePoint sp = s.surface_point(0, 0.2f, 0.3f);
  expect_vec3(sp.geometric_normal, {0, 1, 0});
  expect_vec3(sp.shading_normal, {0, 1, 0});
  expect_vec3(sp.position, {0.3f, 0, 0.2f});  // 0.2 * (0,0,1) + 0.3 * (1,0,0)
}

TEST_F(GltfLoaderTest, NormalsUseInverseTransposeAndMirroringKeepsFrontFaces) {
  Gltf g;
  int pos = g.add_floats(kTriangle, "VEC3");
  const float r = std::sqrt(0.5f);
  int nrm = g.add_floats({r, r, 0, r, r, 0, r, r, 0}, "VEC3");
  // Scale (2,1,1): normals map by diag(1/2,1,1): (0.5,1,0)/|.| = (1,2,0)/sqrt(5).
  Scene s = load("normals.gltf", g.json("\"nodes\":[{\"mesh\":0,\"scale\":[2,1,1]},{\"mesh\":1,"
                                        "\"scale\":[-1,1,1]}],\"meshes\":[" +
                                        triangle_mesh(pos, ",\"NORMAL\":" + std::to_string(nrm)) +
                                        "," + triangle_mesh(pos) + "]"));
  ASSERT_EQ(s.mesh.triangles.size(), 2u);
  expect_vec3(s.mesh.normals[s.mesh.triangles[0].x], glm::vec3(1, 2, 0) / std::sqrt(5.0f));
  // Mirrored by x -> -x: the winding is flipped back so the front face still faces +Z.
  SurfacePoint sp = s.surface_point(1, 0.25f, 0.25f);
  expect_vec3(sp.geometric_normal, {0, 0, 1});
}

TEST_F(GltfLoaderTest, NormalizedTexcoordsAndSecondSet) {
  Gltf g;
  int pos = g.add_floats(kTriangle, "VEC3");
  int uv0 = g.add_u16({0, 0, 65535, 0, 0, 32768}, "VEC2", true);
  int uv1 = g.add_u8({255, 255, 0, 51, 102, 0}, "VEC2", true);
  Scene s =
      load("uv.gltf", g.json("\"nodes\":[{\"mesh\":0}],\"meshes\":[" +
                             triangle_mesh(pos, ",\"TEXCOORD_0\":" + std::to_string(uv0) +
                                                    ",\"TEXCOORD_1\":" + std::to_string(uv1)) +
                             "]"));
  ASSERT_EQ(s.mesh.uv0.size(), 3u);
  ASSERT_EQ(s.mesh.uv1.size(), 3u);
  EXPECT_FLOAT_EQ(s.mesh.uv0[1].x, 1.0f);
  EXPECT_NEAR(s.mesh.uv0[2].y, 32768.0f / 65535.0f, 1e-7);
  EXPECT_FLOAT_EQ(s.mesh.uv1[0].x, 1.0f);
  EXPECT_FLOAT_EQ(s.mesh.uv1[1].y, 0.2f);  // 51 / 255
  EXPECT_FLOAT_EQ(s.mesh.uv1[2].x, 0.4f);  // 102 / 255
}

TEST_F(GltfLoaderTest, InterleavedStrideAndStripsAndSkippedLines) {
  Gltf g;
  // Interleaved: position (3 floats) + 1 float of padding per vertex, byteStride 16.
  std::vector<float> data = {0, 0, 0, 9, 1, 0, 0, 9, 0, 1, 0, 9, 1, 1, 0, 9};
  int view = g.add_view(data.data(), data.size() * sizeof(float), 16);
  int pos = g.add_accessor_json("{\"bufferView\":" + std::to_string(view) +
                                ",\"componentType\":5126,\"count\":4,\"type\":\"VEC3\"}");
  // TRIANGLE_STRIP (5) over 0,1,2,3: (0,1,2), (2,1,3) keep counter-clockwise orientation.
  Scene s = load("strip.gltf", g.json("\"nodes\":[{\"mesh\":0},{\"mesh\":1}],\"meshes\":[" +
                                      triangle_mesh(pos, "", -1, -1, ",\"mode\":5") + "," +
                                      triangle_mesh(pos, "", -1, -1, ",\"mode\":1") + "]"));
  ASSERT_EQ(s.mesh.triangles.size(), 2u);
  for (std::uint32_t t = 0; t < 2; ++t)
    expect_vec3(s.surface_point(t, 0.3f, 0.3f).geometric_normal, {0, 0, 1});
  expect_vec3(s.mesh.positions[s.mesh.triangles[1].y], {1, 1, 0});  // (1, 3, 2)
  int skipped = 0;                                                  // the LINES primitive
  for (const std::string& w : s.warnings) skipped += w.find("skipped") != std::string::npos;
  EXPECT_EQ(skipped, 1);
}

// ---------------------------------------------------------------------------------------------
// Materials and textures

TEST_F(GltfLoaderTest, TextureWrapModesSampleHandComputedTexels) {
  Gltf g;
  int pos = g.add_floats(kTriangle, "VEC3");
  int uv = g.add_floats({0, 0, 1, 0, 0, 1}, "VEC2");
  // 4 x 2 texels; red = 10 * x, green = 100 + 10 * y: every texel is distinguishable.
  std::vector<std::uint8_t> rgb;
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 4; ++x)
      rgb.insert(rgb.end(), {std::uint8_t(10 * x), std::uint8_t(100 + 10 * y), 0});
  std::string image = "data:image/bmp;base64," + base64(bmp(4, 2, rgb));
  std::string materials;
  for (int i = 0; i < 3; ++i)
    materials += std::string(i ? "," : "") +
                 "{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":" + std::to_string(i) +
                 "}}}";
  Scene s = load("wrap.gltf",
                 g.json("\"nodes\":[{\"mesh\":0}],\"meshes\":[" +
                        triangle_mesh(pos, ",\"TEXCOORD_0\":" + std::to_string(uv), -1, 0) +
                        "],\"materials\":[" + materials + "],\"images\":[{\"uri\":\"" + image +
                        "\"}],\"samplers\":["
                        "{\"magFilter\":9728,\"wrapS\":10497,\"wrapT\":10497},"
                        "{\"magFilter\":9728,\"wrapS\":33071,\"wrapT\":33071},"
                        "{\"magFilter\":9728,\"wrapS\":33648,\"wrapT\":33648}],\"textures\":["
                        "{\"source\":0,\"sampler\":0},{\"source\":0,\"sampler\":1},"
                        "{\"source\":0,\"sampler\":2}]"));
  ASSERT_EQ(s.textures.size(), 3u);
  const Texture &repeat = s.textures[0], &clamp = s.textures[1], &mirror = s.textures[2];
  EXPECT_EQ(repeat.wrap_s, Wrap::Repeat);
  EXPECT_EQ(clamp.wrap_s, Wrap::ClampToEdge);
  EXPECT_EQ(mirror.wrap_t, Wrap::MirroredRepeat);
  EXPECT_TRUE(repeat.nearest);
  auto x_of = [](glm::vec4 t) { return static_cast<int>(std::lround(t.r * 255.0f / 10.0f)); };
  auto y_of = [](glm::vec4 t) {
    return static_cast<int>(std::lround((t.g * 255.0f - 100.0f) / 10.0f));
  };
  // u = 1.125 -> texel x = floor(4.5) = 4: repeat 0, clamp 3, mirror (period 8) 8-1-4 = 3.
  EXPECT_EQ(x_of(repeat.sample({1.125f, 0.25f})), 0);
  EXPECT_EQ(x_of(clamp.sample({1.125f, 0.25f})), 3);
  EXPECT_EQ(x_of(mirror.sample({1.125f, 0.25f})), 3);
  // u = -0.125 -> x = -1: repeat 3, clamp 0, mirror 7 -> 8-1-7 = 0.
  EXPECT_EQ(x_of(repeat.sample({-0.125f, 0.25f})), 3);
  EXPECT_EQ(x_of(clamp.sample({-0.125f, 0.25f})), 0);
  EXPECT_EQ(x_of(mirror.sample({-0.125f, 0.25f})), 0);
  // u = 1.375 -> x = 5: repeat 1, clamp 3, mirror 8-1-5 = 2.
  EXPECT_EQ(x_of(repeat.sample({1.375f, 0.25f})), 1);
  EXPECT_EQ(x_of(clamp.sample({1.375f, 0.25f})), 3);
  EXPECT_EQ(x_of(mirror.sample({1.375f, 0.25f})), 2);
  // Rows: v = 0.25 is the top row (y = 0), v = 0.75 the bottom; v = 1.25 wraps to y = 0
  // (repeat), stays at 1 (clamp), mirrors (period 4) 2 -> 4-1-2 = 1.
  EXPECT_EQ(y_of(repeat.sample({0.1f, 0.25f})), 0);
  EXPECT_EQ(y_of(repeat.sample({0.1f, 0.75f})), 1);
  EXPECT_EQ(y_of(repeat.sample({0.1f, 1.25f})), 0);
  EXPECT_EQ(y_of(clamp.sample({0.1f, 1.25f})), 1);
  EXPECT_EQ(y_of(mirror.sample({0.1f, 1.25f})), 1);
}

TEST_F(GltfLoaderTest, MaterialFactorsTexturesAndDefaultMaterial) {
  Gltf g;
  int pos = g.add_floats(kTriangle, "VEC3");
  int uv = g.add_floats({0.5f, 0.5f, 0.5f, 0.5f, 0.5f, 0.5f}, "VEC2");
  // 1x1 textures: base colour sRGB 188 -> linear ((188/255 + 0.055)/1.055)^2.4 = 0.50289;
  // metallic-roughness (R, G, B) = (0, 128, 64): roughness 128/255, metallic 64/255.
  std::string base = "data:image/bmp;base64," + base64(bmp(1, 1, {188, 188, 188}));
  std::string mr = "data:image/bmp;base64," + base64(bmp(1, 1, {0, 128, 64}));
  Scene s =
      load("material.gltf",
           g.json("\"nodes\":[{\"mesh\":0},{\"mesh\":1}],\"meshes\":[" +
                  triangle_mesh(pos, ",\"TEXCOORD_0\":" + std::to_string(uv), -1, 0) + "," +
                  triangle_mesh(pos) +
                  "],\"materials\":[{\"name\":\"glaze\","
                  "\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.5,1,1,1],"
                  "\"baseColorTexture\":{\"index\":0},\"metallicFactor\":1,\"roughnessFactor\":0.5,"
                  "\"metallicRoughnessTexture\":{\"index\":1}},\"doubleSided\":true}],"
                  "\"images\":[{\"uri\":\"" +
                  base + "\"},{\"uri\":\"" + mr +
                  "\"}],"
                  "\"textures\":[{\"source\":0},{\"source\":1}]"));
  ASSERT_EQ(s.materials.size(), 2u);
  EXPECT_EQ(s.materials[0].name, "glaze");
  EXPECT_TRUE(s.materials[0].double_sided);
  EXPECT_EQ(s.materials[1].name, "default");  // glTF's default: white, metallic 1, roughness 1
  EXPECT_EQ(s.mesh.triangle_material[1], 1u);
  EXPECT_FLOAT_EQ(s.materials[1].metallic, 1.0f);

  MaterialPoint mp = s.material_at(s.surface_point(0, 0.3f, 0.3f));
  const float decoded = std::pow((188.0f / 255.0f + 0.055f) / 1.055f, 2.4f);
  EXPECT_NEAR(mp.base_color.r, 0.5f * decoded, 1e-5);
  EXPECT_NEAR(mp.base_color.g, decoded, 1e-5);
  EXPECT_NEAR(mp.roughness, 0.5f * 128.0f / 255.0f, 1e-5);
  EXPECT_NEAR(mp.metallic, 64.0f / 255.0f, 1e-5);
}

TEST_F(GltfLoaderTest, EmissiveStrengthMakesEmittersWeightedByPower) {
  Gltf g;
  // Two emissive triangles: A (area 0.5) with emissive (1,1,1) * 4; B (area 2) with (1,1,1) * 1.
  // Power ~ area * luminance: A = 2, B = 2 -> cdf (0.5, 1). And one non-emissive triangle.
  int a = g.add_floats(kTriangle, "VEC3");
  int b = g.add_floats({0, 0, 1, 2, 0, 1, 0, 2, 1}, "VEC3");
  Scene s = load("emissive.gltf",
                 g.json("\"extensionsUsed\":[\"KHR_materials_emissive_strength\"],"
                        "\"nodes\":[{\"mesh\":0},{\"mesh\":1},{\"mesh\":2}],\"meshes\":[" +
                        triangle_mesh(a, "", -1, 0) + "," + triangle_mesh(b, "", -1, 1) + "," +
                        triangle_mesh(a, "", -1, 2) +
                        "],\"materials\":["
                        "{\"emissiveFactor\":[1,1,1],\"extensions\":{\"KHR_materials_emissive_"
                        "strength\":{\"emissiveStrength\":4}}},"
                        "{\"emissiveFactor\":[1,1,1]},{}]"));
  expect_vec3(s.materials[0].emissive, {4, 4, 4});
  ASSERT_EQ(s.emitters.size(), 2u);
  EXPECT_FLOAT_EQ(s.emitters[0].area, 0.5f);
  EXPECT_FLOAT_EQ(s.emitters[1].area, 2.0f);
  expect_vec3(s.emitters[0].radiance, {4, 4, 4});
  ASSERT_EQ(s.emitter_cdf.size(), 2u);
  EXPECT_NEAR(s.emitter_cdf[0], 0.5f, 1e-6);
  EXPECT_FLOAT_EQ(s.emitter_cdf[1], 1.0f);
  float p = 0.0f;
  EXPECT_EQ(s.sample_emitter(0.7f, &p), 1u);
  EXPECT_NEAR(p, 0.5f, 1e-6);
}

TEST_F(GltfLoaderTest, PunctualLightTransform) {
  Gltf g;
  int pos = g.add_floats(kTriangle, "VEC3");
  const double h = std::sqrt(0.5);
  // Rotation 90 degrees about +X maps the light's -Z to (0, sin 90, -cos 90) = (0, 1, 0).
  Scene s =
      load("light.gltf",
           g.json("\"extensionsUsed\":[\"KHR_lights_punctual\"],\"extensions\":{"
                  "\"KHR_lights_punctual\":{\"lights\":[{\"type\":\"spot\",\"color\":[1,0.5,0.5],"
                  "\"intensity\":5,\"range\":10,\"spot\":{\"innerConeAngle\":0.2,"
                  "\"outerConeAngle\":0.6}}]}},\"nodes\":[{\"mesh\":0},{\"translation\":[1,2,3],"
                  "\"rotation\":[" +
                  std::to_string(h) + ",0,0," + std::to_string(h) +
                  "],\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}}}],\"meshes\":[" +
                  triangle_mesh(pos) + "]"));
  ASSERT_EQ(s.lights.size(), 1u);
  const PunctualLight& l = s.lights[0];
  EXPECT_EQ(l.type, PunctualLight::Type::Spot);
  expect_vec3(l.position, {1, 2, 3});
  expect_vec3(l.direction, {0, 1, 0});
  expect_vec3(l.intensity, {5, 2.5f, 2.5f});
  EXPECT_FLOAT_EQ(l.range, 10.0f);
  EXPECT_FLOAT_EQ(l.inner_cone, 0.2f);
  EXPECT_FLOAT_EQ(l.outer_cone, 0.6f);
}

// ---------------------------------------------------------------------------------------------
// Cameras and scenes

std::string two_cameras(Gltf& g) {
  int pos = g.add_floats(kTriangle, "VEC3");
  return "\"cameras\":[{\"type\":\"perspective\",\"perspective\":{\"yfov\":0.5,\"aspectRatio\":1.5,"
         "\"znear\":0.05},\"extras\":{\"lens\":{\"fstop\":8,\"focus_distance\":1.5}}},"
         "{\"type\":\"perspective\",\"perspective\":{\"yfov\":0.7,\"znear\":0.1}}],"
         "\"nodes\":[{\"mesh\":0},{\"name\":\"left\",\"camera\":0,\"translation\":[0,1,5],"
         "\"scale\":[2,2,2],\"extras\":{\"lens\":{\"focal_length\":0.085,\"fstop\":2.8}}},"
         "{\"name\":\"right\",\"camera\":1,\"translation\":[1,0,5]}],"
         "\"meshes\":[" +
         triangle_mesh(pos) + "]";
}

TEST_F(GltfLoaderTest, CameraLensExtrasAndScaleStripped) {
  Gltf g;
  Scene s = load("cameras.gltf", g.json(two_cameras(g)));
  ASSERT_EQ(s.cameras.size(), 2u);
  const Camera& c = s.cameras[0];
  EXPECT_EQ(c.name, "left");
  EXPECT_FALSE(c.synthesized);
  EXPECT_EQ(c.node, 1);
  EXPECT_FLOAT_EQ(c.yfov, 0.5f);
  ASSERT_TRUE(c.aspect_ratio.has_value());
  EXPECT_FLOAT_EQ(*c.aspect_ratio, 1.5f);
  EXPECT_FLOAT_EQ(c.znear, 0.05f);
  // The node's extras.lens wins over the camera object's key by key.
  ASSERT_TRUE(c.lens.focal_length && c.lens.fstop && c.lens.focus_distance);
  EXPECT_DOUBLE_EQ(*c.lens.focal_length, 0.085);
  EXPECT_DOUBLE_EQ(*c.lens.fstop, 2.8);
  EXPECT_DOUBLE_EQ(*c.lens.focus_distance, 1.5);
  // Scale 2 is stripped: unit axes, translation kept.
  for (int axis = 0; axis < 3; ++axis)
    EXPECT_NEAR(glm::length(glm::vec3(c.camera_to_world[axis])), 1.0f, 1e-6);
  expect_vec3(glm::vec3(c.camera_to_world[3]), {0, 1, 5});
  expect_vec3(glm::vec3(c.camera_to_world[2]), {0, 0, 1});
  EXPECT_FALSE(s.cameras[1].aspect_ratio.has_value());
  EXPECT_FALSE(s.cameras[1].lens.fstop.has_value());
}

// The aperture's shape in extras.lens, key by key like the rest; an absurd one names the node.
TEST_F(GltfLoaderTest, CameraApertureShapeExtras) {
  auto scene_with = [](const std::string& camera_lens, const std::string& node_lens) {
    Gltf g;
    int pos = g.add_floats(kTriangle, "VEC3");
    return g.json("\"cameras\":[{\"type\":\"perspective\",\"perspective\":{\"yfov\":0.5,"
                  "\"znear\":0.05},\"extras\":{\"lens\":" + camera_lens + "}}],"
                  "\"nodes\":[{\"mesh\":0},{\"name\":\"cam\",\"camera\":0,"
                  "\"extras\":{\"lens\":" + node_lens + "}}],\"meshes\":[" +
                  triangle_mesh(pos) + "]");
  };
  Scene s = load("aperture.gltf",
                 scene_with(R"({"aperture_blades": 6, "anamorphic_ratio": 1.5})",
                            R"({"aperture_blades": 5, "aperture_rotation": 10,
                                "vignetting_stop": [0.012, 0.03], "axial_ca": 0.05,
                                "lateral_ca": 0.01, "aperture_profile": "centre",
                                "lens_tilt": [2, 0], "lens_shift": [0, 0.1]})"));
  const lens::ApertureChoices& a = s.cameras[0].lens.aperture;
  ASSERT_TRUE(a.blades && a.rotation_deg && a.anamorphic_ratio);
  EXPECT_EQ(*a.blades, 5);
  EXPECT_DOUBLE_EQ(*a.rotation_deg, 10.0);
  EXPECT_DOUBLE_EQ(*a.anamorphic_ratio, 1.5);
  EXPECT_FALSE(a.roundness.has_value());
  ASSERT_TRUE(a.vignetting_stop.has_value());
  EXPECT_DOUBLE_EQ(a.vignetting_stop->radius, 0.012);
  EXPECT_DOUBLE_EQ(a.vignetting_stop->distance, 0.03);
  EXPECT_DOUBLE_EQ(*a.axial_ca, 0.05);
  EXPECT_DOUBLE_EQ(*a.lateral_ca, 0.01);
  EXPECT_EQ(*a.profile, lens::ApertureProfile::Centre);
  ASSERT_TRUE(a.lens_tilt && a.lens_shift);
  EXPECT_DOUBLE_EQ(a.lens_tilt->first, 2.0);
  EXPECT_DOUBLE_EQ(a.lens_shift->second, 0.1);
  for (const char* bad : {R"({"aperture_blades": 2})", R"({"aperture_blades": 6.5})",
                          R"({"aperture_roundness": 2})", R"({"anamorphic_ratio": 0})",
                          R"({"aperture_rotation": "up"})", R"({"vignetting_stop": [0.01]})",
                          R"({"vignetting_stop": [0, 0.02]})",
                          R"({"vignetting_stop": "wide"})", R"({"lateral_ca": 0.5})",
                          R"({"aperture_profile": "bubble"})", R"({"aperture_profile": 3})",
                          R"({"lens_tilt": [90, 0]})", R"({"lens_shift": [0.1]})"}) {
    const std::string path = write("bad_aperture.gltf", scene_with("{}", bad));
    expect_error([&] { load_gltf(path); }, {path, "cam"});
  }
}

// The draft EXT_camera_physical extension (Khronos glTF pull request 2608): focalLength, fStop and
// focusDistance become the lens where extras.lens says nothing; its values are checked.
TEST_F(GltfLoaderTest, DraftPhysicalCameraExtensionGivesTheLens) {
  auto scene_with = [](const std::string& physical, const std::string& node_lens) {
    Gltf g;
    int pos = g.add_floats(kTriangle, "VEC3");
    return g.json("\"extensionsUsed\":[\"EXT_camera_physical\"],"
                  "\"cameras\":[{\"type\":\"perspective\",\"perspective\":{\"yfov\":0.66059,"
                  "\"znear\":0.01},\"extensions\":{\"EXT_camera_physical\":" + physical + "}}],"
                  "\"nodes\":[{\"mesh\":0},{\"name\":\"cam\",\"camera\":0,"
                  "\"extras\":{\"lens\":" + node_lens + "}}],\"meshes\":[" +
                  triangle_mesh(pos) + "]");
  };
  const std::string draft =
      R"({"focalLength": 0.035, "sensorSize": [0.036, 0.024], "fStop": 2.8, "focusDistance": 5.0})";
  Scene s = load("physical.gltf", scene_with(draft, "{}"));
  const LensExtras& l = s.cameras[0].lens;
  ASSERT_TRUE(l.focal_length && l.fstop && l.focus_distance);
  EXPECT_DOUBLE_EQ(*l.focal_length, 0.035);
  EXPECT_DOUBLE_EQ(*l.fstop, 2.8);
  EXPECT_DOUBLE_EQ(*l.focus_distance, 5.0);
  EXPECT_FLOAT_EQ(s.cameras[0].yfov, 0.66059f);  // the core camera stays the projection
  // extras.lens wins key by key; a focus distance of 0 leaves the focus unset.
  Scene t = load("physical2.gltf",
                 scene_with(R"({"focalLength": 0.035, "sensorSize": [0.036, 0.024],
                               "focusDistance": 0})", R"({"fstop": 1.4, "focal_length": 0.05})"));
  EXPECT_DOUBLE_EQ(*t.cameras[0].lens.focal_length, 0.05);
  EXPECT_DOUBLE_EQ(*t.cameras[0].lens.fstop, 1.4);
  EXPECT_FALSE(t.cameras[0].lens.focus_distance.has_value());
  for (const char* bad : {R"({"focalLength": 0, "sensorSize": [0.036, 0.024]})",
                          R"({"focalLength": 0.05, "sensorSize": [0.036]})",
                          R"({"focalLength": 0.05, "sensorSize": [0.036, 0.024], "fStop": -2})",
                          R"({"focalLength": "long", "sensorSize": [0.036, 0.024]})"}) {
    const std::string path = write("bad_physical.gltf", scene_with(bad, "{}"));
    expect_error([&] { load_gltf(path); }, {path, "EXT_camera_physical"});
  }
}

TEST_F(GltfLoaderTest, CameraSelectionByNameAndErrorListingNames) {
  Gltf g;
  Scene s = load("select.gltf", g.json(two_cameras(g)));
  EXPECT_EQ(s.camera_index("right"), 1u);
  EXPECT_EQ(s.camera_index("left"), 0u);
  try {
    s.camera_index("top");
    FAIL() << "expected dofcache::Error";
  } catch (const Error& e) {
    std::string m = e.what();
    EXPECT_EQ(m.find('\n'), std::string::npos);
    EXPECT_NE(m.find("'top'"), std::string::npos) << m;
    EXPECT_NE(m.find("'left', 'right'"), std::string::npos) << m;
  }
}

TEST_F(GltfLoaderTest, SceneIndexSelection) {
  Gltf g;
  int a = g.add_floats(kTriangle, "VEC3");
  int b = g.add_floats({0, 0, 7, 1, 0, 7, 0, 1, 7}, "VEC3");
  std::string text = g.json(
      "\"scene\":1,\"scenes\":[{\"nodes\":[0]},{\"nodes\":[1]}],"
      "\"nodes\":[{\"mesh\":0},{\"mesh\":1}],\"meshes\":[" +
      triangle_mesh(a) + "," + triangle_mesh(b) + "]");
  Scene by_default = load("scenes.gltf", text);
  EXPECT_FLOAT_EQ(by_default.mesh.positions[0].z, 7.0f);  // the file's default scene is 1
  LoadOptions first;
  first.scene_index = 0;
  Scene chosen = load("scenes.gltf", text, first);
  EXPECT_FLOAT_EQ(chosen.mesh.positions[0].z, 0.0f);
  EXPECT_NE(chosen.content_hash, by_default.content_hash);
}

TEST_F(GltfLoaderTest, SynthesizedCameraFramesTheBounds) {
  Gltf g;
  // Bounds (0,0,0)-(2,2,0): centre (1,1,0), radius = half diagonal = sqrt(2).
  int pos = g.add_floats({0, 0, 0, 2, 0, 0, 0, 2, 0}, "VEC3");
  Scene s = load("nocamera.gltf",
                 g.json("\"nodes\":[{\"mesh\":0}],\"meshes\":[" + triangle_mesh(pos) + "]"));
  ASSERT_EQ(s.cameras.size(), 1u);
  const Camera& c = s.cameras[0];
  EXPECT_TRUE(c.synthesized);
  EXPECT_EQ(c.name, "auto");
  EXPECT_EQ(c.node, -1);
  EXPECT_FLOAT_EQ(c.yfov, 0.8f);
  const float distance = std::sqrt(2.0f) / std::sin(0.4f);  // the sphere fills yfov
  expect_vec3(glm::vec3(c.camera_to_world[3]), {1, 1, distance}, 1e-4f);
  expect_vec3(glm::vec3(c.camera_to_world[2]), {0, 0, 1});  // looks down -Z
}

TEST_F(GltfLoaderTest, MemoryLoadMatchesFileLoad) {
  Gltf g;
  std::string text = g.json(two_cameras(g));
  Scene from_file = load("memory.gltf", text);
  Scene from_memory = load_gltf_from_memory(text, "memory test");
  EXPECT_EQ(from_memory.source, "memory test");
  EXPECT_EQ(from_file.content_hash, from_memory.content_hash);
  EXPECT_NE(from_file.content_hash, 0u);
}

// ---------------------------------------------------------------------------------------------
// Bad input: one dofcache::Error, one line, naming the file and the problem.

TEST_F(GltfLoaderTest, MissingFile) {
  std::string path = (dir() / "does_not_exist.gltf").string();
  expect_error([&] { load_gltf(path); }, {path, "cannot open"});
}

TEST_F(GltfLoaderTest, InvalidJson) {
  std::string path = write("broken.gltf", "{\"asset\": {\"version\": \"2.0\"}, \"nodes\": [ {");
  expect_error([&] { load_gltf(path); }, {path, "invalid JSON", "line 1"});
}

TEST_F(GltfLoaderTest, MissingBufferFile) {
  Gltf g;
  int pos = g.add_floats(kTriangle, "VEC3");
  std::string path = write(
      "nobuffer.gltf", g.json("\"nodes\":[{\"mesh\":0}],\"meshes\":[" + triangle_mesh(pos) + "]",
                              "missing_data.bin"));
  expect_error([&] { load_gltf(path); }, {path, "not found", "missing_data.bin"});
}

TEST_F(GltfLoaderTest, ShortBuffer) {
  Gltf g;
  int pos = g.add_floats(kTriangle, "VEC3");
  // The bufferView claims more bytes than the buffer holds.
  std::string text = g.json("\"nodes\":[{\"mesh\":0}],\"meshes\":[" + triangle_mesh(pos) + "]");
  text.replace(text.find("\"byteLength\":36"), 15, "\"byteLength\":48");
  std::string path = write("short.gltf", text);
  expect_error([&] { load_gltf(path); }, {path, "bufferView 0", "exceeds buffer"});
}

TEST_F(GltfLoaderTest, AccessorOutOfRange) {
  Gltf g;
  std::vector<float> data = kTriangle;
  int view = g.add_view(data.data(), data.size() * sizeof(float));
  // 3 vec3 floats = 36 bytes fit; offset 12 + 3 * 12 = 48 bytes do not.
  int pos = g.add_accessor_json(
      "{\"bufferView\":" + std::to_string(view) +
      ",\"byteOffset\":12,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"}");
  std::string path = write(
      "accessor.gltf", g.json("\"nodes\":[{\"mesh\":0}],\"meshes\":[" + triangle_mesh(pos) + "]"));
  expect_error([&] { load_gltf(path); }, {path, "accessor 0", "POSITION", "exceed bufferView 0"});
}

TEST_F(GltfLoaderTest, IndexOutOfRange) {
  Gltf g;
  int pos = g.add_floats(kTriangle, "VEC3");
  int idx = g.add_u16({0, 1, 7});
  std::string path = write("index.gltf", g.json("\"nodes\":[{\"mesh\":0}],\"meshes\":[" +
                                                triangle_mesh(pos, "", idx) + "]"));
  expect_error([&] { load_gltf(path); }, {path, "indices", "index 7", "out of range"});
}

TEST_F(GltfLoaderTest, NanPosition) {
  Gltf g;
  std::vector<float> data = kTriangle;
  data[4] = std::numeric_limits<float>::quiet_NaN();
  int pos = g.add_floats(data, "VEC3");
  std::string path =
      write("nan.gltf", g.json("\"nodes\":[{\"mesh\":0}],\"meshes\":[" + triangle_mesh(pos) + "]"));
  expect_error([&] { load_gltf(path); }, {path, "POSITION", "vertex 1", "not finite"});
}

TEST_F(GltfLoaderTest, ZeroAreaTriangle) {
  Gltf g;
  // Triangle 1 repeats a vertex.
  int pos = g.add_floats({0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 1, 0, 0}, "VEC3");
  std::string path = write(
      "degenerate.gltf", g.json("\"nodes\":[{\"mesh\":0}],\"meshes\":["
                                "{\"name\":\"Bad\",\"primitives\":[{\"attributes\":{\"POSITION\":" +
                                std::to_string(pos) + "}}]}]"));
  expect_error([&] { load_gltf(path); }, {path, "mesh 'Bad'", "triangle 1", "zero area"});
}

TEST_F(GltfLoaderTest, BadSceneIndex) {
  Gltf g;
  int pos = g.add_floats(kTriangle, "VEC3");
  std::string path =
      write("badscene.gltf", g.json("\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
                                    "\"meshes\":[" +
                                    triangle_mesh(pos) + "]"));
  LoadOptions options;
  options.scene_index = 3;
  expect_error([&] { load_gltf(path, options); }, {path, "scene 3", "out of range"});
}

TEST_F(GltfLoaderTest, BadReferencesAndNoGeometry) {
  Gltf g;
  int pos = g.add_floats(kTriangle, "VEC3");
  std::string bad_mesh = write(
      "badmesh.gltf", g.json("\"nodes\":[{\"mesh\":4}],\"meshes\":[" + triangle_mesh(pos) + "]"));
  expect_error([&] { load_gltf(bad_mesh); }, {bad_mesh, "node (0)", "mesh index 4"});
  std::string bad_material =
      write("badmaterial.gltf",
            g.json("\"nodes\":[{\"mesh\":0}],\"meshes\":[" + triangle_mesh(pos, "", -1, 2) + "]"));
  expect_error([&] { load_gltf(bad_material); }, {bad_material, "material index 2"});
  std::string cycle =
      write("cycle.gltf", g.json("\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"children\":[1]},"
                                 "{\"children\":[0],\"mesh\":0}],\"meshes\":[" +
                                 triangle_mesh(pos) + "]"));
  expect_error([&] { load_gltf(cycle); }, {cycle, "cycle"});
  std::string empty = write("empty.gltf", g.json("\"nodes\":[{\"name\":\"nothing\"}]"));
  expect_error([&] { load_gltf(empty); }, {empty, "no triangle geometry"});
  std::string points =
      write("points.gltf", g.json("\"nodes\":[{\"mesh\":0}],\"meshes\":[" +
                                  triangle_mesh(pos, "", -1, -1, ",\"mode\":0") + "]"));
  expect_error([&] { load_gltf(points); }, {points, "no triangle geometry"});
  std::string extension =
      write("extension.gltf", g.json("\"extensionsRequired\":[\"EXT_meshopt_compression\"],"
                                     "\"nodes\":[{\"mesh\":0}],\"meshes\":[" +
                                     triangle_mesh(pos) + "]"));
  expect_error([&] { load_gltf(extension); }, {extension, "EXT_meshopt_compression"});
  // An extension name with a line break (found by fuzzing): the error stays one line.
  std::string broken =
      write("broken_extension.gltf", g.json("\"extensionsRequired\":[\"KHR_mesh_qu\\ntization\"],"
                                            "\"nodes\":[{\"mesh\":0}],\"meshes\":[" +
                                            triangle_mesh(pos) + "]"));
  expect_error([&] { load_gltf(broken); }, {broken, "KHR_mesh_qu", "tization"});
  expect_error([&] { load_gltf_from_memory("", "empty input"); }, {"empty input"});
}

// The camera frame (scene/transform.h, shared with camera paths) refuses an axis shorter than
// kDegenerateAxisLength, the view axis as well as the up axis (the loader once took any view axis
// longer than 0, where camera paths refused below 1e-12).
TEST_F(GltfLoaderTest, CameraWithCollapsedViewAxisIsRefused) {
  Gltf g;
  int pos = g.add_floats(kTriangle, "VEC3");
  auto with_camera_scale = [&](const std::string& scale) {
    return g.json("\"cameras\":[{\"type\":\"perspective\","
                  "\"perspective\":{\"yfov\":0.5,\"znear\":0.1}}],"
                  "\"nodes\":[{\"mesh\":0},{\"name\":\"cam\",\"camera\":0,\"scale\":" +
                  scale + "}],\"meshes\":[" + triangle_mesh(pos) + "]");
  };
  std::string flat = write("flat_camera.gltf", with_camera_scale("[1,1,1e-13]"));
  expect_error([&] { load_gltf(flat); }, {flat, "node 'cam' (1)", "collapses the view direction"});
  // Above the threshold the frame is rebuilt with unit axes.
  Scene s = load("thin_camera.gltf", with_camera_scale("[1,1,1e-11]"));
  ASSERT_EQ(s.cameras.size(), 1u);
  EXPECT_NEAR(glm::length(glm::vec3(s.cameras[0].camera_to_world[2])), 1.0f, 1e-6);
  expect_vec3(glm::vec3(s.cameras[0].camera_to_world[2]), {0, 0, 1});
}

TEST_F(GltfLoaderTest, GarbageNeverCrashes) {
  // Truncations of a valid file and a GLB header with nonsense lengths: errors, never crashes.
  Gltf g;
  std::string text = g.json(two_cameras(g));
  for (std::size_t n = 0; n < text.size(); n += 7) {
    try {
      load_gltf_from_memory(text.substr(0, n), "truncated");
    } catch (const Error&) {
    }
  }
  // Exactly the literal's 22 bytes: a longer length reads past it (ASan: global buffer overflow).
  std::string glb("glTF\x02\x00\x00\x00\xff\xff\x00\x00\x10\x00\x00\x00JSON{}", 22);
  EXPECT_THROW(load_gltf_from_memory(glb, "bad glb"), Error);
}

// ---------------------------------------------------------------------------------------------
// Limits on hostile input (LoadLimits, docs/reliability.md): refused in one line from what the
// file declares, before the loader allocates for it.

// A PNG of the given size as far as its header goes (IHDR first, then a token IDAT and IEND):
// enough for the size check, which must refuse it before anything tries to decode it.
std::vector<unsigned char> png_header(std::uint32_t w, std::uint32_t h) {
  std::vector<unsigned char> out = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  auto u32 = [&](std::uint32_t v) {
    for (int shift = 24; shift >= 0; shift -= 8) out.push_back((v >> shift) & 0xff);
  };
  auto chunk = [&](const char* tag, const std::vector<unsigned char>& data) {
    u32(static_cast<std::uint32_t>(data.size()));
    out.insert(out.end(), tag, tag + 4);
    out.insert(out.end(), data.begin(), data.end());
    u32(0);  // CRC: not reached
  };
  std::vector<unsigned char> ihdr;
  for (std::uint32_t v : {w, h})
    for (int shift = 24; shift >= 0; shift -= 8) ihdr.push_back((v >> shift) & 0xff);
  ihdr.insert(ihdr.end(), {8, 6, 0, 0, 0});
  chunk("IHDR", ihdr);
  chunk("IDAT", {0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01});
  chunk("IEND", {});
  return out;
}

TEST_F(GltfLoaderTest, BillionsOfDeclaredVerticesAreRefused) {
  Gltf g;
  int view = g.add_view(kTriangle.data(), kTriangle.size() * sizeof(float));
  int pos = g.add_accessor_json("{\"bufferView\":" + std::to_string(view) +
                                ",\"componentType\":5126,\"count\":3000000000,"
                                "\"type\":\"VEC3\"}");
  std::string path =
      write("billions.gltf", g.json("\"nodes\":[{\"mesh\":0}],\"meshes\":[" +
                                    triangle_mesh(pos) + "]"));
  expect_error([&] { load_gltf(path); }, {path, "3000000000 elements", "exceed"});
  // Without a bufferView nothing bounds the count by bytes: the vertex limit does.
  Gltf z;
  z.add_floats(kTriangle, "VEC3");  // a buffer for the file to have (its accessor is unused)
  int zeros = z.add_accessor_json(
      "{\"componentType\":5126,\"count\":3000000000,\"type\":\"VEC3\"}");
  std::string no_view =
      write("billions_no_view.gltf", z.json("\"nodes\":[{\"mesh\":0}],\"meshes\":[" +
                                            triangle_mesh(zeros) + "]"));
  expect_error([&] { load_gltf(no_view); }, {no_view, "implausible count 3000000000"});
}

TEST_F(GltfLoaderTest, VertexAndTriangleLimitsCountEveryMeshInstance) {
  Gltf g;
  int pos = g.add_floats(kTriangle, "VEC3");
  // Three nodes place three meshes sharing one accessor: 9 vertices, 3 triangles in all.
  std::string path = write(
      "instances.gltf",
      g.json("\"nodes\":[{\"mesh\":0},{\"mesh\":1,\"translation\":[2,0,0]},"
             "{\"mesh\":2,\"translation\":[4,0,0]}],\"meshes\":[" +
             triangle_mesh(pos) + "," + triangle_mesh(pos) + "," + triangle_mesh(pos) + "]"));
  LoadOptions options;
  options.limits.max_vertices = 9;
  options.limits.max_triangles = 3;
  EXPECT_EQ(load_gltf(path, options).mesh.triangles.size(), 3u);  // exactly at the limits
  options.limits.max_vertices = 8;
  expect_error([&] { load_gltf(path, options); },
               {path, "mesh (2) primitive 0", "vertex limit (8", "--max-vertices"});
  options.limits.max_vertices = 9;
  options.limits.max_triangles = 2;
  expect_error([&] { load_gltf(path, options); },
               {path, "triangle limit (2", "--max-triangles"});
}

TEST_F(GltfLoaderTest, HugeTextureIsRefusedFromItsHeader) {
  Gltf g;
  int pos = g.add_floats(kTriangle, "VEC3");
  auto with_image = [&](const std::vector<unsigned char>& bytes, const std::string& mime) {
    return g.json("\"nodes\":[{\"mesh\":0}],\"meshes\":[" + triangle_mesh(pos, "", -1, 0) +
                  "],\"materials\":[{\"pbrMetallicRoughness\":{\"baseColorTexture\":"
                  "{\"index\":0}}}],\"textures\":[{\"source\":0}],\"images\":[{\"uri\":\"data:" +
                  mime + ";base64," + base64(bytes) + "\"}]");
  };
  // 100000^2 RGBA would be 40 GB decoded (160 GB as float texels).
  std::string huge = write("huge_texture.gltf", with_image(png_header(100000, 100000), "image/png"));
  expect_error([&] { load_gltf(huge); },
               {huge, "image 0", "100000x100000", "texture limit", "--max-texture-pixels"});
  // The limit is on all images together, and exact.
  std::string small = write("small_texture.gltf",
                            with_image(bmp(4, 2, std::vector<std::uint8_t>(24, 7)), "image/bmp"));
  LoadOptions options;
  options.limits.max_texture_pixels = 8;
  EXPECT_EQ(load_gltf(small, options).textures.at(0).width, 4);
  options.limits.max_texture_pixels = 7;
  expect_error([&] { load_gltf(small, options); }, {small, "4x2 pixels", "texture limit (7"});
}

TEST_F(GltfLoaderTest, ImageBufferViewOutsideItsBufferIsRefused) {
  // tinygltf hands an image's bufferView to the decoder without checking its byte range.
  Gltf g;
  int pos = g.add_floats(kTriangle, "VEC3");
  int view = g.add_view_json("{\"buffer\":0,\"byteOffset\":16,\"byteLength\":100000}");
  std::string path = write(
      "image_view.gltf",
      g.json("\"nodes\":[{\"mesh\":0}],\"meshes\":[" + triangle_mesh(pos) +
             "],\"images\":[{\"bufferView\":" + std::to_string(view) +
             ",\"mimeType\":\"image/png\"}]"));
  expect_error([&] { load_gltf(path); }, {path, "image 0", "exceeds its buffer"});
}

TEST_F(GltfLoaderTest, DeepNodeHierarchyIsRefused) {
  Gltf g;
  int pos = g.add_floats(kTriangle, "VEC3");
  auto chain = [&](int depth) {  // node k's child is k + 1; the last one has the mesh
    std::string nodes;
    for (int k = 0; k < depth; ++k)
      nodes += std::string(k ? "," : "") +
               (k + 1 < depth ? "{\"children\":[" + std::to_string(k + 1) + "]}"
                              : std::string("{\"mesh\":0}"));
    return g.json("\"scenes\":[{\"nodes\":[0]}],\"nodes\":[" + nodes + "],\"meshes\":[" +
                  triangle_mesh(pos) + "]");
  };
  std::string deep = write("deep.gltf", chain(5000));
  expect_error([&] { load_gltf(deep); },
               {deep, "node (1000)", "node depth limit (1000", "--max-node-depth"});
  LoadOptions options;
  options.limits.max_node_depth = 5000;
  EXPECT_EQ(load_gltf(deep, options).mesh.triangles.size(), 1u);
  options.limits.max_node_depth = 4999;
  expect_error([&] { load_gltf(deep, options); }, {deep, "node (4999)", "depth limit"});
}

TEST_F(GltfLoaderTest, NodeReachedTwiceIsRefused) {
  // Shared children would multiply everything below them: 2^depth copies for a chain of pairs.
  Gltf g;
  int pos = g.add_floats(kTriangle, "VEC3");
  std::string shared = write(
      "shared_child.gltf",
      g.json("\"scenes\":[{\"nodes\":[0,1]}],\"nodes\":[{\"children\":[2]},"
             "{\"children\":[2]},{\"mesh\":0}],\"meshes\":[" + triangle_mesh(pos) + "]"));
  expect_error([&] { load_gltf(shared); }, {shared, "node (2)", "reached twice", "trees"});
  std::string twice = write("root_twice.gltf",
                            g.json("\"scenes\":[{\"nodes\":[0,0]}],\"nodes\":[{\"mesh\":0}],"
                                   "\"meshes\":[" + triangle_mesh(pos) + "]"));
  expect_error([&] { load_gltf(twice); }, {twice, "node (0)", "reached twice"});
}

}  // namespace
}  // namespace dofcache::scene
