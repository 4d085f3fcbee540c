// scenes/generate_atrium.py (the scale benchmark's scene) at a small size: the file it writes
// loads with the layout it promises, into arrays without unused memory, the same on any number
// of threads; it renders visibly, and its leaves are cut out by their texture's alpha in the
// intersector. Skipped where python3 is not installed.
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <set>
#include <string>

#include <glm/geometric.hpp>
#include <tbb/global_control.h>

#include "dofcache/render/renderer.h"
#include "dofcache/render/setup.h"
#include "dofcache/scene/accel.h"
#include "dofcache/scene/gltf_loader.h"
#include "scratch_dir.h"

namespace dofcache::render {
namespace {

class GeneratedAtrium : public testing::ScratchDirTest {
 protected:
  void SetUp() override {
    ScratchDirTest::SetUp();
    if (std::system("python3 --version > /dev/null 2>&1") != 0)
      GTEST_SKIP() << "python3 is not installed";
    file_ = path("atrium.glb");
    const std::string command = "python3 '" + std::string(DOFCACHE_SOURCE_DIR) +
                                "/scenes/generate_atrium.py' '" + file_ +
                                "' --triangles 20000 --texture-size 32 > /dev/null";
    ASSERT_EQ(std::system(command.c_str()), 0) << command;
  }

  std::string file_;
};

// Indices of the materials called `name` (the generator names them).
std::uint32_t material_named(const scene::Scene& s, const std::string& name) {
  for (std::size_t m = 0; m < s.materials.size(); ++m)
    if (s.materials[m].name == name) return static_cast<std::uint32_t>(m);
  ADD_FAILURE() << "no material " << name;
  return 0;
}

TEST_F(GeneratedAtrium, LoadsAtTheRequestedSizeWithItsTexturesCutOutsAndLens) {
  scene::Scene s = scene::load_gltf(file_);
  EXPECT_TRUE(s.warnings.empty()) << s.warnings.front();
  // --triangles is a target the tessellation rounds up to: within a few percent above it.
  EXPECT_GE(s.mesh.triangles.size(), 20000u);
  EXPECT_LE(s.mesh.triangles.size(), 22000u);
  EXPECT_EQ(s.textures.size(), 11u);
  EXPECT_EQ(s.materials.size(), 8u);
  for (const char* leaf : {"leaf_a", "leaf_b"}) {
    const scene::Material& m = s.materials[material_named(s, leaf)];
    EXPECT_EQ(m.alpha_mode, scene::AlphaMode::Mask) << leaf;
    EXPECT_TRUE(m.double_sided) << leaf;
    ASSERT_GE(m.base_color_texture.index, 0) << leaf;
    // The leaf texture is partly transparent: a leaf shape, not a rectangle.
    const scene::Texture& t = s.textures[static_cast<std::size_t>(m.base_color_texture.index)];
    std::size_t clear = 0;
    for (const glm::vec4& texel : t.texels) clear += texel.a < 0.5f;
    EXPECT_GT(clear, t.texels.size() / 5) << leaf;
    EXPECT_LT(clear, t.texels.size() * 4 / 5) << leaf;
  }
  // Normal textures on the columns and walls: tangents generated for them.
  EXPECT_GE(s.materials[material_named(s, "marble")].normal_texture.index, 0);
  EXPECT_EQ(s.mesh.tangents.size(), s.mesh.positions.size());
  EXPECT_EQ(s.emitters.size(), 6u);  // three skylight quads
  ASSERT_EQ(s.cameras.size(), 1u);
  const scene::Camera& c = s.cameras[0];
  EXPECT_FALSE(c.synthesized);
  EXPECT_DOUBLE_EQ(*c.lens.focal_length, 0.035);
  EXPECT_DOUBLE_EQ(*c.lens.fstop, 2.0);
  // Focused on the third pair of columns, 12 m down the nave: between 11 and 12.5 m on the axis.
  EXPECT_GT(*c.lens.focus_distance, 11.0);
  EXPECT_LT(*c.lens.focus_distance, 12.5);
  // The hall: 16 m wide, 12 m high, from the entrance wall (z = 1) 36 m down -z.
  EXPECT_NEAR(s.bounds.lower.x, -8.0f, 1e-4f);
  EXPECT_NEAR(s.bounds.upper.x, 8.0f, 1e-4f);
  EXPECT_NEAR(s.bounds.upper.y, 12.0f, 1e-4f);
  EXPECT_NEAR(s.bounds.lower.z, -36.0f, 1e-4f);
}

// The loader keeps no memory it does not use: attributes no primitive has are freed, the others
// hold little more than their elements (docs/scenes.md, "Scale"). Positions keep room for one
// more vertex, which Embree's 16-byte loads read.
TEST_F(GeneratedAtrium, MeshArraysHoldNoUnusedMemory) {
  scene::Scene s = scene::load_gltf(file_);
  const scene::Mesh& m = s.mesh;
  EXPECT_EQ(m.uv1.capacity(), 0u);     // the file has no TEXCOORD_1
  EXPECT_EQ(m.colors.capacity(), 0u);  // nor COLOR_0
  auto tight = [](std::size_t capacity, std::size_t size) {
    return capacity >= size && capacity <= size + size / 64 + 1;
  };
  EXPECT_TRUE(tight(m.positions.capacity(), m.positions.size() + 1)) << m.positions.capacity();
  EXPECT_GT(m.positions.capacity(), m.positions.size());
  EXPECT_TRUE(tight(m.normals.capacity(), m.normals.size())) << m.normals.capacity();
  EXPECT_TRUE(tight(m.uv0.capacity(), m.uv0.size())) << m.uv0.capacity();
  EXPECT_TRUE(tight(m.tangents.capacity(), m.tangents.size())) << m.tangents.capacity();
  EXPECT_TRUE(tight(m.triangles.capacity(), m.triangles.size())) << m.triangles.capacity();
  EXPECT_TRUE(tight(m.triangle_material.capacity(), m.triangle_material.size()));
  EXPECT_TRUE(tight(m.triangle_object.capacity(), m.triangle_object.size()));
}

// Tangent generation runs in parallel (scene/tangents.cpp): the scene, tangents included, is
// the same bits on one thread as on all.
TEST_F(GeneratedAtrium, LoadsTheSameOnOneThreadAsOnAll) {
  scene::Scene parallel = scene::load_gltf(file_);
  scene::Scene serial = [&] {
    tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
    return scene::load_gltf(file_);
  }();
  EXPECT_EQ(parallel.content_hash, serial.content_hash);
  ASSERT_EQ(parallel.mesh.tangents.size(), serial.mesh.tangents.size());
  ASSERT_FALSE(serial.mesh.tangents.empty());
  EXPECT_EQ(std::memcmp(parallel.mesh.tangents.data(), serial.mesh.tangents.data(),
                        serial.mesh.tangents.size() * sizeof(glm::vec4)),
            0);
}

// For leaf triangles, a ray straight through the leaf where its texture is clear passes, and one
// where it is opaque stops: MASK cut-outs work on the generated foliage.
TEST_F(GeneratedAtrium, LeavesAreCutOutWhereTheirTextureIsClear) {
  scene::Scene s = scene::load_gltf(file_);
  scene::Accel accel(s);
  const std::uint32_t leaf_a = material_named(s, "leaf_a"), leaf_b = material_named(s, "leaf_b");
  int passed = 0, stopped = 0, leaves = 0;
  for (std::uint32_t t = 0; t < s.mesh.triangles.size() && leaves < 200; ++t) {
    const std::uint32_t m = s.mesh.triangle_material[t];
    if (m != leaf_a && m != leaf_b) continue;
    ++leaves;
    const glm::uvec3 tri = s.mesh.triangles[t];
    const glm::vec3 p0 = s.mesh.positions[tri.x], p1 = s.mesh.positions[tri.y],
                    p2 = s.mesh.positions[tri.z];
    const glm::vec3 n = glm::normalize(glm::cross(p1 - p0, p2 - p0));
    // A few points inside the triangle; each ray starts 1 mm in front and ends 1 mm behind, so
    // nothing but this leaf (and leaves crossing it there, rare) can be hit.
    for (float u : {0.1f, 0.3f, 0.5f, 0.7f})
      for (float v : {0.1f, 0.2f}) {
        if (u + v > 0.95f) continue;
        const glm::vec3 p = (1.0f - u - v) * p0 + u * p1 + v * p2;
        scene::Ray ray;
        ray.origin = p + 1e-3f * n;
        ray.direction = -n;
        ray.tfar = 2e-3f;
        const bool opaque = s.alpha_at(t, u, v) >= s.materials[m].alpha_cutoff;
        const scene::Hit hit = accel.intersect(ray);
        if (opaque) {
          EXPECT_TRUE(hit.valid()) << "leaf triangle " << t << " at " << u << ", " << v;
          ++stopped;
        } else {
          if (hit.valid()) {
            EXPECT_NE(hit.triangle, t) << "cut-out hit at " << u << ", " << v;
          }
          ++passed;
        }
      }
  }
  EXPECT_EQ(leaves, 200);
  EXPECT_GT(passed, 50);
  EXPECT_GT(stopped, 50);
}

TEST_F(GeneratedAtrium, RendersVisiblyWithColumnsAndLeavesInView) {
  scene::Scene s = scene::load_gltf(file_);
  scene::Accel accel(s);
  const scene::Camera& camera = s.cameras[0];
  RenderSettings settings;
  settings.width = 48;
  settings.height = height_for_width(camera, settings.width);
  settings.spp = 2;
  settings.lens = resolve_lens(s, accel, camera, {}).lens;
  settings.progress = Progress::Display::Never;
  RenderOutput out = render(s, accel, camera, settings);
  double sum = 0.0;
  for (int y = 0; y < out.color.height(); ++y)
    for (int x = 0; x < out.color.width(); ++x)
      for (int c = 0; c < 3; ++c) sum += out.color.at(x, y, c);
  EXPECT_GT(sum / (3.0 * out.color.width() * out.color.height()), 0.02);
  // Object ids are node indices: the camera sees columns and bushes (nodes named by the
  // generator; their indices found by the triangles they own).
  std::set<int> seen;
  for (int y = 0; y < out.ids.height(); ++y)
    for (int x = 0; x < out.ids.width(); ++x) seen.insert(static_cast<int>(out.ids.at(x, y, 0)));
  const std::uint32_t marble = material_named(s, "marble"), leaf_a = material_named(s, "leaf_a"),
                      leaf_b = material_named(s, "leaf_b");
  bool column = false, bush = false;
  for (std::uint32_t t = 0; t < s.mesh.triangles.size(); ++t) {
    if (!seen.count(static_cast<int>(s.mesh.triangle_object[t]))) continue;
    const std::uint32_t m = s.mesh.triangle_material[t];
    column |= m == marble;
    bush |= m == leaf_a || m == leaf_b;
  }
  EXPECT_TRUE(column);
  EXPECT_TRUE(bush);
}

}  // namespace
}  // namespace dofcache::render
