// glTF 2.0 features beyond plain geometry, each on a small file built here with the expected
// values computed by hand in the comments: sparse accessors, KHR_mesh_quantization, COLOR_0,
// KHR_texture_transform, normal textures and tangents, alpha modes, doubleSided and the
// KHR_draco_mesh_compression fallback; and the one-line refusal of each kind of bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include <unistd.h>
#include <glm/geometric.hpp>
#include <zlib.h>

#include "dofcache/core/error.h"
#include "dofcache/scene/accel.h"
#include "dofcache/scene/gltf_loader.h"
#include "dofcache/scene/tangents.h"
#include "scene/gltf_builder.h"

namespace dofcache::scene {
namespace {

namespace fs = std::filesystem;
using test::base64;
using test::expect_error;
using test::bmp;
using test::Gltf;

const std::vector<float> kTriangle = {0, 0, 0, 1, 0, 0, 0, 1, 0};

fs::path scratch() {
  static fs::path d = [] {
    fs::path p =
        fs::temp_directory_path() / ("dofcache_gltf_features_test_" + std::to_string(::getpid()));
    fs::create_directories(p);
    return p;
  }();
  return d;
}

class GltfFeaturesTest : public ::testing::Test {
 protected:
  static std::string write(const std::string& name, const std::string& text) {
    fs::path p = scratch() / name;
    std::ofstream(p, std::ios::binary) << text;
    return p.string();
  }
  static Scene load(const std::string& name, const std::string& text) {
    return load_gltf(write(name, text));
  }
  static void TearDownTestSuite() { fs::remove_all(scratch()); }
};

std::string attr(const char* name, int accessor) {
  return std::string(",\"") + name + "\":" + std::to_string(accessor);
}

// One node, one mesh of one primitive.
std::string one_primitive(int position, const std::string& attributes, int material = -1,
                          const std::string& node = "{\"mesh\":0}") {
  return "\"nodes\":[" + node + "],\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":" +
         std::to_string(position) + attributes + "}" +
         (material >= 0 ? ",\"material\":" + std::to_string(material) : "") + "}]}]";
}

void expect_vec3(glm::vec3 actual, glm::vec3 expected, float tol = 1e-5f) {
  EXPECT_NEAR(actual.x, expected.x, tol);
  EXPECT_NEAR(actual.y, expected.y, tol);
  EXPECT_NEAR(actual.z, expected.z, tol);
}


// A sparse accessor object: `count` substitutions, indices (UNSIGNED_SHORT) and values in the
// given bufferViews.
std::string sparse(int count, int index_view, int value_view) {
  return ",\"sparse\":{\"count\":" + std::to_string(count) +
         ",\"indices\":{\"bufferView\":" + std::to_string(index_view) +
         ",\"componentType\":5123},\"values\":{\"bufferView\":" + std::to_string(value_view) +
         "}}";
}

// ---------------------------------------------------------------------------------------------
// Sparse accessors

TEST_F(GltfFeaturesTest, SparseAccessorReplacesElementsOfItsBaseView) {
  Gltf g;
  // Base: the unit triangle (0,0,0) (1,0,0) (0,1,0); sparse: element 2 becomes (0,3,0).
  std::vector<float> base = kTriangle, value = {0, 3, 0};
  std::vector<std::uint16_t> index = {2, 0};  // padded to 4 bytes
  int base_view = g.add_view(base.data(), base.size() * 4);
  int index_view = g.add_view(index.data(), 4);
  int value_view = g.add_view(value.data(), value.size() * 4);
  int pos = g.add_accessor_json("{\"bufferView\":" + std::to_string(base_view) +
                                ",\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"" +
                                sparse(1, index_view, value_view) + "}");
  Scene s = load("sparse_base.gltf", g.json(one_primitive(pos, "")));
  ASSERT_EQ(s.mesh.positions.size(), 3u);
  expect_vec3(s.mesh.positions[0], {0, 0, 0});
  expect_vec3(s.mesh.positions[1], {1, 0, 0});
  expect_vec3(s.mesh.positions[2], {0, 3, 0});
}

TEST_F(GltfFeaturesTest, SparseAccessorWithoutBufferViewStartsFromZeros) {
  Gltf g;
  // Four zero vertices; sparse sets 1, 2 and 3: the triangles (0,1,2) and (0,2,3) become the
  // unit square (1,0,0) (1,1,0) (0,1,0) around the origin.
  std::vector<std::uint16_t> index = {1, 2, 3, 0};
  std::vector<float> values = {1, 0, 0, 1, 1, 0, 0, 1, 0};
  std::vector<std::uint8_t> tris = {0, 1, 2, 0, 2, 3};
  int index_view = g.add_view(index.data(), 8);
  int value_view = g.add_view(values.data(), values.size() * 4);
  int pos = g.add_accessor_json("{\"componentType\":5126,\"count\":4,\"type\":\"VEC3\"" +
                                sparse(3, index_view, value_view) + "}");
  int idx = g.add_u8(tris);
  Scene s = load("sparse_zero.gltf",
                 g.json("\"nodes\":[{\"mesh\":0}],\"meshes\":[{\"primitives\":[{\"attributes\":"
                        "{\"POSITION\":" + std::to_string(pos) + "},\"indices\":" +
                        std::to_string(idx) + "}]}]"));
  ASSERT_EQ(s.mesh.triangles.size(), 2u);
  expect_vec3(s.mesh.positions[s.mesh.triangles[0].x], {0, 0, 0});
  expect_vec3(s.mesh.positions[s.mesh.triangles[0].y], {1, 0, 0});
  expect_vec3(s.mesh.positions[s.mesh.triangles[0].z], {1, 1, 0});
  expect_vec3(s.mesh.positions[s.mesh.triangles[1].z], {0, 1, 0});
}

TEST_F(GltfFeaturesTest, BadSparseIndicesAreRefusedInOneLine) {
  auto file = [](std::vector<std::uint16_t> index, int count) {
    Gltf g;
    std::vector<float> base = kTriangle, values = {0, 2, 0, 0, 3, 0};
    int base_view = g.add_view(base.data(), base.size() * 4);
    int index_view = g.add_view(index.data(), index.size() * 2);
    int value_view = g.add_view(values.data(), values.size() * 4);
    int pos = g.add_accessor_json("{\"bufferView\":" + std::to_string(base_view) +
                                  ",\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"" +
                                  sparse(count, index_view, value_view) + "}");
    return g.json(one_primitive(pos, ""));
  };
  std::string out_of_range = write("sparse_range.gltf", file({1, 3}, 2));
  expect_error([&] { load_gltf(out_of_range); }, {out_of_range, "sparse index 3", "out of range"});
  std::string repeated = write("sparse_order.gltf", file({2, 2}, 2));
  expect_error([&] { load_gltf(repeated); }, {repeated, "strictly increase"});
  std::string too_many = write("sparse_count.gltf", file({0, 1}, 4));
  expect_error([&] { load_gltf(too_many); }, {too_many, "sparse count 4"});
  // Indices beyond their bufferView (2 shorts declared 8 values' worth).
  Gltf g;
  std::vector<float> base = kTriangle, values = {0, 2, 0};
  std::vector<std::uint16_t> index = {1, 0};
  int base_view = g.add_view(base.data(), base.size() * 4);
  int index_view = g.add_view(index.data(), 4);
  int value_view = g.add_view(values.data(), values.size() * 4);
  int pos = g.add_accessor_json("{\"bufferView\":" + std::to_string(base_view) +
                                ",\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"" +
                                sparse(3, index_view, value_view) + "}");
  std::string short_view = write("sparse_view.gltf", g.json(one_primitive(pos, "")));
  expect_error([&] { load_gltf(short_view); }, {short_view, "sparse indices", "exceed"});
}

// ---------------------------------------------------------------------------------------------
// KHR_mesh_quantization and COLOR_0

TEST_F(GltfFeaturesTest, QuantizedAttributesAreDequantizedByTheNodeTransform) {
  Gltf g;
  // SHORT positions (not normalised) 0 and 200, the node scales by 0.005 and moves by (1,0,0):
  // (0,0,0) (200,0,0) (0,200,0) -> (1,0,0) (2,0,0) (1,1,0).
  int pos = g.add_i16({0, 0, 0, 200, 0, 0, 0, 200, 0}, "VEC3", false);
  // Normalised BYTE normals: 127 -> 1, -127 -> -1 (and -128 clamps to -1).
  int nrm = g.add_i8({0, 0, 127, 0, 0, 127, 0, 0, 127}, "VEC3", true);
  // Normalised UNSIGNED_SHORT texture coordinates: 65535 -> 1, 13107 -> 0.2.
  int uv = g.add_u16({0, 0, 65535, 13107, 0, 65535}, "VEC2", true);
  Scene s = load("quantized.gltf",
                 g.json("\"extensionsUsed\":[\"KHR_mesh_quantization\"],"
                        "\"extensionsRequired\":[\"KHR_mesh_quantization\"]," +
                        one_primitive(pos, attr("NORMAL", nrm) + attr("TEXCOORD_0", uv), -1,
                                      "{\"mesh\":0,\"scale\":[0.005,0.005,0.005],"
                                      "\"translation\":[1,0,0]}")));
  ASSERT_EQ(s.mesh.positions.size(), 3u);
  expect_vec3(s.mesh.positions[0], {1, 0, 0});
  expect_vec3(s.mesh.positions[1], {2, 0, 0});
  expect_vec3(s.mesh.positions[2], {1, 1, 0});
  expect_vec3(s.mesh.normals[1], {0, 0, 1});
  EXPECT_NEAR(s.mesh.uv0[1].y, 0.2f, 1e-6);
  EXPECT_NEAR(s.mesh.uv0[2].y, 1.0f, 1e-6);
}

TEST_F(GltfFeaturesTest, VertexColorsMultiplyTheBaseColor) {
  Gltf g;
  int pos = g.add_floats(kTriangle, "VEC3");
  // Three primitives with the same material (baseColorFactor (0.5, 1, 1, 0.8)):
  // float VEC3 colours; normalised UNSIGNED_BYTE VEC4 (255, 51, 0, 102) -> (1, 0.2, 0, 0.4);
  // normalised UNSIGNED_SHORT VEC4 (65535, 0, 13107, 65535) -> (1, 0, 0.2, 1).
  int rgb = g.add_floats({0.2f, 0.4f, 0.6f, 0.2f, 0.4f, 0.6f, 0.2f, 0.4f, 0.6f}, "VEC3");
  int rgba8 = g.add_u8({255, 51, 0, 102, 255, 51, 0, 102, 255, 51, 0, 102}, "VEC4", true);
  int rgba16 = g.add_u16({65535, 0, 13107, 65535, 65535, 0, 13107, 65535, 65535, 0, 13107, 65535},
                         "VEC4", true);
  std::string meshes;
  for (int c : {rgb, rgba8, rgba16})
    meshes += std::string(meshes.empty() ? "" : ",") +
              "{\"primitives\":[{\"attributes\":{\"POSITION\":" + std::to_string(pos) +
              attr("COLOR_0", c) + "},\"material\":0}]}";
  Scene s = load("colors.gltf",
                 g.json("\"nodes\":[{\"mesh\":0},{\"mesh\":1},{\"mesh\":2}],\"meshes\":[" + meshes +
                        "],\"materials\":[{\"alphaMode\":\"BLEND\",\"pbrMetallicRoughness\":"
                        "{\"baseColorFactor\":[0.5,1,1,0.8]}}]"));
  ASSERT_EQ(s.mesh.triangles.size(), 3u);
  expect_vec3(s.material_at(s.surface_point(0, 0.3f, 0.3f)).base_color, {0.1f, 0.4f, 0.6f});
  expect_vec3(s.material_at(s.surface_point(1, 0.3f, 0.3f)).base_color, {0.5f, 0.2f, 0.0f});
  expect_vec3(s.material_at(s.surface_point(2, 0.3f, 0.3f)).base_color, {0.5f, 0.0f, 0.2f});
  // Alpha: 0.8 * 1 (VEC3: opaque), 0.8 * 0.4, 0.8 * 1.
  EXPECT_NEAR(s.alpha_at(0, 0.3f, 0.3f), 0.8f, 1e-6);
  EXPECT_NEAR(s.alpha_at(1, 0.3f, 0.3f), 0.32f, 1e-6);
  EXPECT_NEAR(s.alpha_at(2, 0.3f, 0.3f), 0.8f, 1e-6);
}

TEST_F(GltfFeaturesTest, VertexColorsOfAnotherTypeAreRefused) {
  Gltf g;
  int pos = g.add_floats(kTriangle, "VEC3");
  int bytes = g.add_u8({255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255}, "VEC4", false);
  std::string file = write("color_type.gltf", g.json(one_primitive(pos, attr("COLOR_0", bytes))));
  expect_error([&] { load_gltf(file); }, {file, "COLOR_0", "normalized"});
  Gltf h;
  int pos2 = h.add_floats(kTriangle, "VEC3");
  int two = h.add_floats({1, 1, 1, 1, 1, 1}, "VEC2");
  std::string vec2 = write("color_vec2.gltf", h.json(one_primitive(pos2, attr("COLOR_0", two))));
  expect_error([&] { load_gltf(vec2); }, {vec2, "COLOR_0", "VEC4"});
}

// ---------------------------------------------------------------------------------------------
// KHR_texture_transform and texCoord

// A 4 x 4 texture whose texel (x, y) has green 20 + 50 x and blue 20 + 50 y, sampled nearest as
// the metallic-roughness texture: roughness = green / 255, metallic = blue / 255 tell which texel
// a point reads.
std::string texel_finder_file(Gltf& g, const std::vector<std::string>& texture_infos,
                              const std::string& more_attributes) {
  int pos = g.add_floats(kTriangle, "VEC3");
  // TEXCOORD_0 is (0.1, 0.2) all over the triangle.
  int uv = g.add_floats({0.1f, 0.2f, 0.1f, 0.2f, 0.1f, 0.2f}, "VEC2");
  std::vector<std::uint8_t> rgb;
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x)
      rgb.insert(rgb.end(), {0, std::uint8_t(20 + 50 * x), std::uint8_t(20 + 50 * y)});
  std::string meshes, materials, nodes;
  for (std::size_t i = 0; i < texture_infos.size(); ++i) {
    std::string sep = i ? "," : "";
    nodes += sep + "{\"mesh\":" + std::to_string(i) + "}";
    meshes += sep + "{\"primitives\":[{\"attributes\":{\"POSITION\":" + std::to_string(pos) +
              attr("TEXCOORD_0", uv) + more_attributes + "},\"material\":" + std::to_string(i) +
              "}]}";
    materials += sep + "{\"pbrMetallicRoughness\":{\"metallicRoughnessTexture\":" +
                 texture_infos[i] + "}}";
  }
  return g.json("\"extensionsUsed\":[\"KHR_texture_transform\"],\"nodes\":[" + nodes +
                "],\"meshes\":[" + meshes + "],\"materials\":[" + materials +
                "],\"images\":[{\"uri\":\"data:image/bmp;base64," + base64(bmp(4, 4, rgb)) +
                "\"}],\"samplers\":[{\"magFilter\":9728}],"
                "\"textures\":[{\"source\":0,\"sampler\":0}]");
}

glm::ivec2 texel_read(const Scene& s, std::uint32_t triangle) {
  MaterialPoint mp = s.material_at(s.surface_point(triangle, 0.3f, 0.3f));
  return {static_cast<int>(std::lround((mp.roughness * 255.0f - 20.0f) / 50.0f)),
          static_cast<int>(std::lround((mp.metallic * 255.0f - 20.0f) / 50.0f))};
}

TEST_F(GltfFeaturesTest, TextureTransformOffsetRotationScaleAndTexCoord) {
  Gltf g;
  int uv1 = g.add_floats({0.9f, 0.6f, 0.9f, 0.6f, 0.9f, 0.6f}, "VEC2");
  const std::string ext = ",\"extensions\":{\"KHR_texture_transform\":";
  Scene s = load(
      "transform.gltf",
      texel_finder_file(
          g,
          {// Untransformed: (0.1, 0.2) -> texel (floor 0.4, floor 0.8) = (0, 0).
           "{\"index\":0}",
           // Offset (0.5, 0.25): (0.6, 0.45) -> texel (2, 1).
           "{\"index\":0" + ext + "{\"offset\":[0.5,0.25]}}}",
           // Scale (2, 1), then rotation pi/2 as [c s; -s c]: (0.2, 0.2) -> (0.2, -0.2) ->
           // texel (0, floor(-0.8) = -1 -> 3 by REPEAT).
           "{\"index\":0" + ext + "{\"scale\":[2,1],\"rotation\":1.5707963267948966}}}",
           // texCoord 1 on the textureInfo: (0.9, 0.6) -> texel (3, 2).
           "{\"index\":0,\"texCoord\":1}",
           // The extension's texCoord overrides the textureInfo's: set 1 with offset (0.25, 0)
           // -> (1.15, 0.6) -> texel (floor 4.6 = 4 -> 0, 2).
           "{\"index\":0,\"texCoord\":0" + ext + "{\"texCoord\":1,\"offset\":[0.25,0]}}}"},
          attr("TEXCOORD_1", uv1)));
  ASSERT_EQ(s.mesh.triangles.size(), 5u);
  EXPECT_EQ(texel_read(s, 0), glm::ivec2(0, 0));
  EXPECT_EQ(texel_read(s, 1), glm::ivec2(2, 1));
  EXPECT_EQ(texel_read(s, 2), glm::ivec2(0, 3));
  EXPECT_EQ(texel_read(s, 3), glm::ivec2(3, 2));
  EXPECT_EQ(texel_read(s, 4), glm::ivec2(0, 2));
  EXPECT_EQ(s.materials[4].metallic_roughness_texture.texcoord, 1);
  for (const std::string& w : s.warnings)
    EXPECT_EQ(w.find("KHR_texture_transform"), std::string::npos) << w;
}

TEST_F(GltfFeaturesTest, BadTextureTransformsAreRefusedInOneLine) {
  const std::string ext = ",\"extensions\":{\"KHR_texture_transform\":";
  struct Case {
    std::string info, expected;
  };
  for (const Case& c : std::vector<Case>{
           {"{\"offset\":[1e300,0]}", "offset must be a finite number"},
           {"{\"scale\":[1,2,3]}", "scale must have 2 numbers"},
           {"{\"rotation\":\"x\"}", "rotation must be a finite number"},
           {"{\"rotation\":2e6}", "rotation must be a finite number"},
           {"{\"texCoord\":-1}", "texCoord must be an integer"}}) {
    Gltf g;
    std::string file = write("bad_transform.gltf",
                             texel_finder_file(g, {"{\"index\":0" + ext + c.info + "}}"}, ""));
    expect_error([&] { load_gltf(file); }, {file, "KHR_texture_transform", c.expected});
  }
}

// ---------------------------------------------------------------------------------------------
// Normal textures and tangents

// A 1x1 normal texture of RGB (218, 128, 218): tangent-space normal c = 2 rgb / 255 - 1.
const glm::vec3 kMapped(2.0f * 218 / 255 - 1, 2.0f * 128 / 255 - 1, 2.0f * 218 / 255 - 1);

std::string normal_mapped_file(Gltf& g, const std::string& attributes, int pos,
                               double scale = 1.0) {
  return g.json(one_primitive(pos, attributes, 0) +
                ",\"materials\":[{\"normalTexture\":{\"index\":0,\"scale\":" +
                std::to_string(scale) +
                "}}],\"images\":[{\"uri\":\"data:image/bmp;base64," +
                base64(bmp(1, 1, {218, 128, 218})) + "\"}],\"textures\":[{\"source\":0}]");
}

TEST_F(GltfFeaturesTest, NormalTextureWithGeneratedTangents) {
  // The unit triangle in z = 0 (normal +z) with u along +x and v along +y: tangent (1,0,0),
  // bitangent (0,1,0) = cross(n, t), so w = +1; n' = normalize(c.x t + c.y b + c.z n).
  {
    Gltf g;
    int pos = g.add_floats(kTriangle, "VEC3");
    int nrm = g.add_floats({0, 0, 1, 0, 0, 1, 0, 0, 1}, "VEC3");
    int uv = g.add_floats({0, 0, 1, 0, 0, 1}, "VEC2");
    Scene s = load("normal_map.gltf",
                   normal_mapped_file(g, attr("NORMAL", nrm) + attr("TEXCOORD_0", uv), pos));
    ASSERT_EQ(s.mesh.tangents.size(), 3u);
    EXPECT_EQ(s.mesh.tangents[0], glm::vec4(1, 0, 0, 1));
    expect_vec3(s.material_at(s.surface_point(0, 0.2f, 0.3f)).normal, glm::normalize(kMapped));
  }
  // u running along -x (mirrored texture): tangent (-1,0,0), bitangent (0,1,0) while
  // cross(n, t) = (0,-1,0): w = -1; n' = normalize(-c.x x + c.y y + c.z z). Scale 0.5 halves
  // c.x and c.y. No NORMAL: flat shading, the tangents are generated on the copied vertices.
  {
    Gltf g;
    int pos = g.add_floats(kTriangle, "VEC3");
    int uv = g.add_floats({1, 0, 0, 0, 1, 1}, "VEC2");
    Scene s = load("normal_map_mirrored.gltf",
                   normal_mapped_file(g, attr("TEXCOORD_0", uv), pos, 0.5));
    ASSERT_EQ(s.mesh.tangents.size(), 3u);
    EXPECT_EQ(s.mesh.tangents[1], glm::vec4(-1, 0, 0, -1));
    expect_vec3(s.material_at(s.surface_point(0, 0.2f, 0.3f)).normal,
                glm::normalize(glm::vec3(-0.5f * kMapped.x, 0.5f * kMapped.y, kMapped.z)));
  }
}

TEST_F(GltfFeaturesTest, NormalTextureWithTangentsFromTheFile) {
  Gltf g;
  int pos = g.add_floats(kTriangle, "VEC3");
  int nrm = g.add_floats({0, 0, 1, 0, 0, 1, 0, 0, 1}, "VEC3");
  int uv = g.add_floats({0, 0, 1, 0, 0, 1}, "VEC2");
  // The file says tangent (0,1,0) with w = -1: bitangent = -cross(z, y) = (1,0,0), whatever the
  // UVs would give: n' = normalize(c.x y + c.y x + c.z z).
  int tan = g.add_floats({0, 1, 0, -1, 0, 1, 0, -1, 0, 1, 0, -1}, "VEC4");
  Scene s = load("tangents.gltf",
                 normal_mapped_file(g,
                                    attr("NORMAL", nrm) + attr("TEXCOORD_0", uv) +
                                        attr("TANGENT", tan),
                                    pos));
  ASSERT_EQ(s.mesh.tangents.size(), 3u);
  EXPECT_EQ(s.mesh.tangents[2], glm::vec4(0, 1, 0, -1));
  expect_vec3(s.material_at(s.surface_point(0, 0.2f, 0.3f)).normal,
              glm::normalize(glm::vec3(kMapped.y, kMapped.x, kMapped.z)));

  // A TANGENT accessor of three components is refused.
  Gltf h;
  int pos2 = h.add_floats(kTriangle, "VEC3");
  int vec3 = h.add_floats({0, 1, 0, 0, 1, 0, 0, 1, 0}, "VEC3");
  std::string bad = write("tangent_vec3.gltf",
                          normal_mapped_file(h, attr("TANGENT", vec3), pos2));
  expect_error([&] { load_gltf(bad); }, {bad, "TANGENT", "VEC4"});
}

TEST(Tangents, AreOrthogonalToTheNormalWithHandednessFromTheBitangent) {
  // A quad in the x-z plane, normal +y tilted: the vertex normal (0, 1, 1)/sqrt2 makes
  // Gram-Schmidt visible. u along +x, v along -z: tangent (1,0,0) stays (orthogonal already);
  // bitangent -z against cross(n, t) = (0, 1, -1)/sqrt2: positive, w = +1.
  std::vector<glm::vec3> p = {{0, 0, 0}, {1, 0, 0}, {1, 0, -1}, {0, 0, -1}};
  glm::vec3 n = glm::normalize(glm::vec3(0, 1, 1));
  std::vector<glm::vec3> normals(4, n);
  std::vector<glm::vec2> uv = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  std::vector<glm::uvec3> tris = {{0, 1, 2}, {0, 2, 3}};
  std::vector<glm::vec4> t = generate_tangents(p, normals, uv, tris, 0, 0);
  ASSERT_EQ(t.size(), 4u);
  for (const glm::vec4& v : t) {
    EXPECT_NEAR(v.x, 1.0f, 1e-6);
    EXPECT_NEAR(glm::dot(glm::vec3(v), n), 0.0f, 1e-6);
    EXPECT_EQ(v.w, 1.0f);
  }
  // Tangent along a diagonal: u along (1,0,-1) gets projected off a normal tilted towards it.
  std::vector<glm::vec2> diagonal = {{0, 0}, {0.5f, -0.5f}, {1, 0}, {0.5f, 0.5f}};
  t = generate_tangents(p, normals, diagonal, tris, 0, 0);
  // Both triangles give dp/du = (1, 0, -1) (solving e1 = du1 T + dv1 B, e2 = du2 T + dv2 B);
  // minus its part along n = (0,1,1)/sqrt2 (-1/sqrt2): (1, 0.5, -0.5), normalised.
  expect_vec3(glm::vec3(t[0]), glm::normalize(glm::vec3(1, 0.5f, -0.5f)));
}

// ---------------------------------------------------------------------------------------------
// JPEG, emissive textures, TEXCOORD_1

// A 4 x 4 baseline JPEG (oiiotool --pattern checker:width=2:height=2 4x4 3): 2 x 2 blocks of
// black and white, black at the top left; decoded, black is 0 and white 255 (to 1 unit).
const char* kCheckerJpeg =
    "/9j/4AAQSkZJRgABAQAAAQABAAD/4QESRXhpZgAASUkqALYAAABvaWlvdG9vbCAtLXBhdHRlcm4gY2hlY2tlcjp3aWR0"
    "aD0yOmhlaWdodD0yIDR4NCAzIC1vIC90bXAvdG1wbmk2dnlrdmYvdC5qcGcAT3BlbkltYWdlSU8gMi40LjcuMSA6IG9p"
    "aW90b29sIC0tcGF0dGVybiBjaGVja2VyOndpZHRoPTI6aGVpZ2h0PTIgNHg0IDMgLW8gL3RtcC90bXBuaTZ2eWt2Zi90"
    "LmpwZwACADEBAgBiAAAAVAAAAGmHBAABAAAA1AAAAAAAAAAEAACQBwAEAAAAMDIzMAGRBwAEAAAAAQIDABOSAgBMAAAA"
    "CAAAAACgBwAEAAAAMDEwMAAAAAD/7QCCUGhvdG9zaG9wIDMuMAA4QklNBAQAAAAAAGYcAkEAYU9wZW5JbWFnZUlPIDIu"
    "NC43LjEgOiBvaWlvdG9vbCAtLXBhdHRlcm4gY2hlY2tlcjp3aWR0aD0yOmhlaWdodD0yIDR4NCAzIC1vIC90bXAvdG1w"
    "bmk2dnlrdmYvdC5qcGf/2wBDAAEBAQEBAQEBAQEBAQEBAQIBAQEBAQIBAQECAgICAgICAgIDAwQDAwMDAwICAwQDAwQE"
    "BAQEAgMFBQQEBQQEBAT/2wBDAQEBAQEBAQIBAQIEAwIDBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQE"
    "BAQEBAQEBAQEBAQEBAT/wAARCAAEAAQDASIAAhEBAxEB/8QAHwAAAQUBAQEBAQEAAAAAAAAAAAECAwQFBgcICQoL/8QA"
    "tRAAAgEDAwIEAwUFBAQAAAF9AQIDAAQRBRIhMUEGE1FhByJxFDKBkaEII0KxwRVS0fAkM2JyggkKFhcYGRolJicoKSo0"
    "NTY3ODk6Q0RFRkdISUpTVFVWV1hZWmNkZWZnaGlqc3R1dnd4eXqDhIWGh4iJipKTlJWWl5iZmqKjpKWmp6ipqrKztLW2"
    "t7i5usLDxMXGx8jJytLT1NXW19jZ2uHi4+Tl5ufo6erx8vP09fb3+Pn6/8QAHwEAAwEBAQEBAQEBAQAAAAAAAAECAwQF"
    "BgcICQoL/8QAtREAAgECBAQDBAcFBAQAAQJ3AAECAxEEBSExBhJBUQdhcRMiMoEIFEKRobHBCSMzUvAVYnLRChYkNOEl"
    "8RcYGRomJygpKjU2Nzg5OkNERUZHSElKU1RVVldYWVpjZGVmZ2hpanN0dXZ3eHl6goOEhYaHiImKkpOUlZaXmJmaoqOk"
    "paanqKmqsrO0tba3uLm6wsPExcbHyMnK0tPU1dbX2Nna4uPk5ebn6Onq8vP09fb3+Pn6/9oADAMBAAIRAxEAPwD8/P8A"
    "gqP/AMFR/wBuz/gi5+3Z8c/+CaP/AATR+Of/AAzZ+xL+zZ/wjP8AwpX4K/8ACsvB3xi/4Qv/AITHwd4e8f8AiP8A4qPx"
    "VpOq69efbNe8Va9f/wCn38/k/b/Jh8qCKGGMoooA/9k=";

std::string unbase64(const std::string& in) {
  std::string out;
  int bits = 0;
  std::uint32_t acc = 0;
  for (char c : in) {
    const char* alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    const char* at = c ? std::strchr(alphabet, c) : nullptr;
    if (!at) continue;  // '=' padding
    acc = acc << 6 | static_cast<std::uint32_t>(at - alphabet);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out += static_cast<char>((acc >> bits) & 0xff);
    }
  }
  return out;
}

TEST_F(GltfFeaturesTest, EmissiveJpegTextureFromAFileOnTheSecondTexcoordSet) {
  const std::string jpeg = unbase64(kCheckerJpeg);
  write("checker.jpg", jpeg);
  Gltf g;
  int pos = g.add_floats(kTriangle, "VEC3");
  // TEXCOORD_1 (0.125, 0.125) on the first primitive (texel (0, 0): black), (0.625, 0.125) on
  // the second (texel (2, 0): white); TEXCOORD_0 points elsewhere (the other colour) and must
  // not be used.
  int uv0a = g.add_floats({0.625f, 0.125f, 0.625f, 0.125f, 0.625f, 0.125f}, "VEC2");
  int uv1a = g.add_floats({0.125f, 0.125f, 0.125f, 0.125f, 0.125f, 0.125f}, "VEC2");
  int uv0b = g.add_floats({0.125f, 0.125f, 0.125f, 0.125f, 0.125f, 0.125f}, "VEC2");
  int uv1b = g.add_floats({0.625f, 0.125f, 0.625f, 0.125f, 0.625f, 0.125f}, "VEC2");
  auto mesh = [&](int uv0, int uv1) {
    return "{\"primitives\":[{\"attributes\":{\"POSITION\":" + std::to_string(pos) +
           attr("TEXCOORD_0", uv0) + attr("TEXCOORD_1", uv1) + "},\"material\":0}]}";
  };
  std::string file = g.json("\"nodes\":[{\"mesh\":0},{\"mesh\":1}],\"meshes\":[" +
                            mesh(uv0a, uv1a) + "," + mesh(uv0b, uv1b) +
                            "],\"materials\":[{\"emissiveFactor\":[2,2,2],\"emissiveTexture\":"
                            "{\"index\":0,\"texCoord\":1}}],\"images\":[{\"uri\":"
                            "\"checker.jpg\"}],\"samplers\":[{\"magFilter\":9728}],"
                            "\"textures\":[{\"source\":0,\"sampler\":0}]");
  Scene s = load("emissive_jpeg.gltf", file);
  ASSERT_EQ(s.mesh.triangles.size(), 2u);
  // Emission = factor 2 times the sRGB-decoded texel: 0 and 2 (255 -> 1; 254 -> 0.991).
  EXPECT_LT(s.material_at(s.surface_point(0, 0.3f, 0.3f)).emission.r, 0.01f);
  EXPECT_GT(s.material_at(s.surface_point(1, 0.3f, 0.3f)).emission.g, 1.98f);
  // Only the white triangle emits, with its mean radiance.
  ASSERT_EQ(s.emitters.size(), 1u);
  EXPECT_EQ(s.emitters[0].triangle, 1u);

  // The same JPEG cut in half: refused in one line, nothing half-decoded.
  write("checker.jpg", jpeg.substr(0, jpeg.size() / 2));
  std::string truncated = write("truncated_jpeg.gltf", file);
  expect_error([&] { load_gltf(truncated); }, {truncated});
}

// ---------------------------------------------------------------------------------------------
// Alpha modes and doubleSided in the intersector

// Two unit squares facing +z, in z = -1 (material 0) and z = -2 (material 1, opaque,
// double-sided), seen by rays down -z from (x, y, 0).
Scene two_squares(const Material& front) {
  Scene s;
  s.mesh.positions = {{0, 0, -1}, {1, 0, -1}, {1, 1, -1}, {0, 1, -1},
                      {0, 0, -2}, {1, 0, -2}, {1, 1, -2}, {0, 1, -2}};
  s.mesh.normals.assign(8, glm::vec3(0, 0, 1));
  s.mesh.triangles = {{0, 1, 2}, {0, 2, 3}, {4, 5, 6}, {4, 6, 7}};
  s.mesh.triangle_material = {0, 0, 1, 1};
  s.mesh.triangle_object = {0, 0, 1, 1};
  s.materials = {front, Material{}};
  s.materials[1].double_sided = true;
  return s;
}

Ray down(float x, float y, std::uint32_t seed = 0) {
  Ray r;
  r.origin = {x, y, 0};
  r.direction = {0, 0, -1};
  r.seed = seed;
  return r;
}

TEST(AlphaAndSides, MaskCutsOutCameraRaysAndShadowsAlike) {
  Material m;
  m.alpha_mode = AlphaMode::Mask;
  m.alpha_cutoff = 0.5f;
  m.base_color.a = 0.4f;  // below the cutoff: cut out everywhere
  Scene s = two_squares(m);
  Accel cut(s);
  Hit hit = cut.intersect(down(0.5f, 0.25f));
  ASSERT_TRUE(hit.valid());
  EXPECT_NEAR(hit.t, 2.0f, 1e-6);  // through to the back square
  Ray shadow = down(0.5f, 0.25f);
  shadow.tfar = 1.5f;  // ends between the squares: only the cut-out one lies on it
  EXPECT_FALSE(cut.occluded(shadow));

  s.materials[0].base_color.a = 0.5f;  // at the cutoff: opaque (alpha >= cutoff)
  Accel kept(s);
  EXPECT_NEAR(kept.intersect(down(0.5f, 0.25f)).t, 1.0f, 1e-6);
  EXPECT_TRUE(kept.occluded(shadow));
}

TEST(AlphaAndSides, MaskFollowsVertexAlphaAcrossATriangle) {
  // COLOR_0 alpha 0 at (0,0) and (1,1), 1 at (1,0) and (0,1); cutoff 0.5. Along y = 0.25 in the
  // first triangle (0,0) (1,0) (1,1): alpha = u (the weight of (1,0)) = x - y, so the surface is
  // there for x - 0.25 >= 0.5, i.e. x >= 0.75.
  Material m;
  m.alpha_mode = AlphaMode::Mask;
  Scene s = two_squares(m);
  s.mesh.colors.assign(8, glm::vec4(1.0f));
  s.mesh.colors[0].a = s.mesh.colors[2].a = 0.0f;
  Accel accel(s);
  EXPECT_NEAR(accel.intersect(down(0.7f, 0.25f)).t, 2.0f, 1e-6);
  EXPECT_NEAR(accel.intersect(down(0.8f, 0.25f)).t, 1.0f, 1e-6);
}

TEST(AlphaAndSides, BlendLetsRaysThroughWithProbabilityOneMinusAlpha) {
  Material m;
  m.alpha_mode = AlphaMode::Blend;
  m.base_color.a = 0.25f;
  Scene s = two_squares(m);
  Accel accel(s);
  const int n = 4000;
  int front = 0;
  for (int i = 0; i < n; ++i) front += accel.intersect(down(0.5f, 0.25f, i)).t < 1.5f;
  // Binomial(4000, 0.25): mean 1000, standard deviation sqrt(4000 * 0.25 * 0.75) = 27.4.
  EXPECT_NEAR(front, 1000, 4 * 27.4);
  // The same ray with the same seed always gets the same answer, shadows included.
  for (std::uint32_t seed : {1u, 2u, 3u, 77u}) {
    float t = accel.intersect(down(0.5f, 0.25f, seed)).t;
    for (int k = 0; k < 3; ++k) EXPECT_EQ(accel.intersect(down(0.5f, 0.25f, seed)).t, t);
  }
  int blocked = 0;
  for (int i = 0; i < n; ++i) {
    Ray shadow = down(0.5f, 0.25f, i);
    shadow.tfar = 1.5f;
    blocked += accel.occluded(shadow);
  }
  EXPECT_NEAR(blocked, 1000, 4 * 27.4);
}

TEST(AlphaAndSides, SingleSidedBackFacesAreCulledForCameraRaysOnly) {
  // The front square is single-sided and faces +z; seen from below (rays up +z from z = -3), the
  // back square (double-sided) is met first at t = 1 anyway, so put the origin between them.
  Scene s = two_squares(Material{});
  Accel accel(s);
  Ray up;
  up.origin = {0.5f, 0.25f, -1.5f};
  up.direction = {0, 0, 1};
  up.cull_back_faces = true;  // a camera ray: the back of the single-sided square is not there
  EXPECT_FALSE(accel.intersect(up).valid());
  up.cull_back_faces = false;  // light transport: it is
  Hit hit = accel.intersect(up);
  ASSERT_TRUE(hit.valid());
  EXPECT_NEAR(hit.t, 0.5f, 1e-6);
  EXPECT_TRUE(accel.occluded(up));
  // The double-sided square seen from behind is there for camera rays too.
  Ray back = up;
  back.cull_back_faces = true;
  back.origin.z = -3.0f;
  EXPECT_NEAR(accel.intersect(back).t, 1.0f, 1e-6);
}

// ---------------------------------------------------------------------------------------------
// Draco

// A Draco-compressed primitive as encoders write it: the extension points at the compressed
// bytes, the accessors describe the decoded data but have no bufferView (no uncompressed
// fallback), the indices accessor included. `extensions` holds extensionsUsed/Required.
std::string draco_without_fallback(const std::string& extensions) {
  Gltf g;
  const float compressed[4] = {1, 2, 3, 4};  // stands for the Draco bytes
  g.add_view(compressed, sizeof compressed);
  int pos = g.add_accessor_json(
      "{\"componentType\":5126,\"count\":4,\"type\":\"VEC3\",\"max\":[1,1,0],\"min\":[0,0,0]}");
  int idx = g.add_accessor_json("{\"componentType\":5123,\"count\":6,\"type\":\"SCALAR\"}");
  return g.json(extensions +
                "\"nodes\":[{\"mesh\":0}],\"meshes\":[{\"primitives\":[{\"attributes\":"
                "{\"POSITION\":" + std::to_string(pos) + "},\"indices\":" + std::to_string(idx) +
                ",\"extensions\":{\"KHR_draco_mesh_compression\":{\"bufferView\":0,"
                "\"attributes\":{\"POSITION\":0}}}}]}]");
}

TEST_F(GltfFeaturesTest, DracoIsRefusedNamingTheExtensionUnlessThereIsAFallback) {
  const std::string used = "\"extensionsUsed\":[\"KHR_draco_mesh_compression\"],";
  const std::string required =
      used + "\"extensionsRequired\":[\"KHR_draco_mesh_compression\"],";
  // Only used, with the uncompressed fallback: the fallback is what is loaded.
  {
    Gltf g;
    int pos = g.add_floats({0, 0, 0, 2, 0, 0, 0, 2, 0}, "VEC3");
    int idx = g.add_u16({0, 1, 2}, "SCALAR");
    Scene s = load("draco_fallback.gltf",
                   g.json(used + "\"nodes\":[{\"mesh\":0}],\"meshes\":[{\"primitives\":[{"
                                 "\"attributes\":{\"POSITION\":" + std::to_string(pos) +
                          "},\"indices\":" + std::to_string(idx) +
                          ",\"extensions\":{\"KHR_draco_mesh_compression\":{\"bufferView\":0,"
                          "\"attributes\":{\"POSITION\":0}}}}]}]"));
    ASSERT_EQ(s.mesh.positions.size(), 3u);
    expect_vec3(s.mesh.positions[1], {2, 0, 0});
  }
  // Only used, without a fallback: refused in one line naming the extension.
  std::string no_fallback = write("draco_used.gltf", draco_without_fallback(used));
  expect_error([&] { load_gltf(no_fallback); },
               {no_fallback, "KHR_draco_mesh_compression", "no uncompressed fallback"});
  // Required: refused as an unsupported extension, as .gltf and as .glb (JSON chunk only).
  std::string json = draco_without_fallback(required);
  std::string file = write("draco_required.gltf", json);
  expect_error([&] { load_gltf(file); },
               {file, "unsupported extension KHR_draco_mesh_compression"});
  json.append((4 - json.size() % 4) % 4, ' ');
  std::string glb = "glTF";
  auto put = [&](std::uint32_t v) { glb.append(reinterpret_cast<const char*>(&v), 4); };
  put(2), put(static_cast<std::uint32_t>(20 + json.size()));
  put(static_cast<std::uint32_t>(json.size())), put(0x4E4F534Au);  // "JSON"
  glb += json;
  std::string binary = write("draco_required.glb", glb);
  expect_error([&] { load_gltf(binary); },
               {binary, "unsupported extension KHR_draco_mesh_compression"});
}

TEST_F(GltfFeaturesTest, AlphaModesAreReadAndAnUnknownOneRefused) {
  Gltf g;
  int pos = g.add_floats(kTriangle, "VEC3");
  Scene s = load("alpha.gltf",
                 g.json(one_primitive(pos, "", 0) +
                        ",\"materials\":[{\"alphaMode\":\"MASK\",\"alphaCutoff\":0.25,"
                        "\"doubleSided\":true},{\"alphaMode\":\"BLEND\"},{}]"));
  EXPECT_EQ(s.materials[0].alpha_mode, AlphaMode::Mask);
  EXPECT_FLOAT_EQ(s.materials[0].alpha_cutoff, 0.25f);
  EXPECT_TRUE(s.materials[0].double_sided);
  EXPECT_EQ(s.materials[1].alpha_mode, AlphaMode::Blend);
  EXPECT_EQ(s.materials[2].alpha_mode, AlphaMode::Opaque);
  EXPECT_FALSE(s.materials[2].double_sided);
  for (const std::string& w : s.warnings) EXPECT_EQ(w.find("alphaMode"), std::string::npos) << w;
  std::string bad = write("alpha_bad.gltf", g.json(one_primitive(pos, "", 0) +
                                                   ",\"materials\":[{\"alphaMode\":\"CLIP\"}]"));
  expect_error([&] { load_gltf(bad); }, {bad, "alphaMode 'CLIP'"});
}


// ---------------------------------------------------------------------------------------------
// Hostile PNG textures: refused in one line before stb_image allocates what they declare

// A PNG of `width` x `height` RGBA pixels whose IDAT chunk holds `idat` (CRCs are not checked by
// the guard; zeros), with `idat_length` declared for it.
std::vector<unsigned char> png_file(std::uint32_t width, std::uint32_t height,
                                    const std::vector<unsigned char>& idat,
                                    std::uint32_t idat_length) {
  std::vector<unsigned char> f = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  auto u32 = [&](std::uint32_t v) {
    for (int s = 24; s >= 0; s -= 8) f.push_back(static_cast<unsigned char>(v >> s));
  };
  auto chunk = [&](const char* type, const std::vector<unsigned char>& data, std::uint32_t length) {
    u32(length);
    f.insert(f.end(), type, type + 4);
    f.insert(f.end(), data.begin(), data.end());
    u32(0);  // CRC
  };
  std::vector<unsigned char> ihdr;
  for (std::uint32_t v : {width, height})
    for (int s = 24; s >= 0; s -= 8) ihdr.push_back(static_cast<unsigned char>(v >> s));
  ihdr.insert(ihdr.end(), {8, 6, 0, 0, 0});  // 8-bit RGBA, not interlaced
  chunk("IHDR", ihdr, 13);
  chunk("IDAT", idat, idat_length);
  chunk("IEND", {}, 0);
  return f;
}

std::string png_textured_file(const std::vector<unsigned char>& png) {
  Gltf g;
  int pos = g.add_floats(kTriangle, "VEC3");
  int uv = g.add_floats({0, 0, 1, 0, 0, 1}, "VEC2");
  return g.json(one_primitive(pos, attr("TEXCOORD_0", uv), 0) +
                ",\"materials\":[{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0}}}]"
                ",\"images\":[{\"uri\":\"data:image/png;base64," + base64(png) +
                "\"}],\"textures\":[{\"source\":0}]");
}

TEST_F(GltfFeaturesTest, PngChunkLongerThanTheFileIsRefusedInOneLine) {
  // What fuzzing found: an IDAT declaring 1.8 GB in a file of a few dozen bytes, which stb_image
  // allocated before reading.
  const std::string bad = write("png_chunk.gltf", png_textured_file(png_file(2, 2, {1, 2, 3},
                                                                             0x6ad88011u)));
  expect_error([&] { load_gltf(bad); }, {bad, "image 0", "declares 1792573457 bytes"});
}

TEST_F(GltfFeaturesTest, PngDataInflatingPastItsSizeIsRefusedInOneLine) {
  // 8 MB of zeros compress to a few kilobytes; a 2x2 RGBA image holds 2 x (1 + 8) bytes.
  std::vector<unsigned char> zeros(8u << 20, 0);
  uLongf packed_size = compressBound(static_cast<uLong>(zeros.size()));
  std::vector<unsigned char> packed(packed_size);
  ASSERT_EQ(compress2(packed.data(), &packed_size, zeros.data(), static_cast<uLong>(zeros.size()), 9),
            Z_OK);
  packed.resize(packed_size);
  ASSERT_LT(packed.size(), 64u * 1024);
  const std::string bomb = write("png_bomb.gltf", png_textured_file(png_file(
                                                      2, 2, packed, std::uint32_t(packed.size()))));
  expect_error([&] { load_gltf(bomb); }, {bomb, "image 0", "inflates to more than its 2x2"});

  // The same image with its true data loads (the guard refuses only what overflows).
  const std::vector<unsigned char> rows = {0, 255, 0, 0, 255, 0, 255, 0, 255,
                                           0, 0, 0, 255, 255, 255, 255, 255, 255};
  uLongf ok_size = compressBound(static_cast<uLong>(rows.size()));
  std::vector<unsigned char> ok(ok_size);
  ASSERT_EQ(compress2(ok.data(), &ok_size, rows.data(), static_cast<uLong>(rows.size()), 9), Z_OK);
  ok.resize(ok_size);
  const std::string fine = write("png_fine.gltf", png_textured_file(png_file(
                                                      2, 2, ok, std::uint32_t(ok.size()))));
  EXPECT_NO_THROW(load_gltf(fine));
}

}  // namespace
}  // namespace dofcache::scene
