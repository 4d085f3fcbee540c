// The Embree accelerator: hit distance and barycentrics against hand-computed values, shadow-ray
// segments, and concurrent queries.
#include "dofcache/scene/accel.h"

#include <gtest/gtest.h>

#include <atomic>
#include <string>
#include <thread>
#include <vector>

#include "dofcache/scene/gltf_loader.h"

namespace dofcache::scene {
namespace {

// Two triangles facing +Z: A = (0,0,-2), (1,0,-2), (0,1,-2); B = A shifted to z = -4.
Scene two_triangles() {
  Scene s;
  s.mesh.positions = {{0, 0, -2}, {1, 0, -2}, {0, 1, -2}, {0, 0, -4}, {1, 0, -4}, {0, 1, -4}};
  s.mesh.normals.assign(6, glm::vec3(0, 0, 1));
  s.mesh.triangles = {{0, 1, 2}, {3, 4, 5}};
  s.mesh.triangle_material = {0, 0};
  s.mesh.triangle_object = {0, 1};
  s.materials.resize(1);
  s.mesh.positions.shrink_to_fit();  // no spare capacity: exercises the padded-copy path
  return s;
}

TEST(Accel, HitDistanceAndBarycentrics) {
  Scene s = two_triangles();
  Accel accel(s);
  // From (0.25, 0.5, 0) straight down -Z: hits A at t = 2 with p = (1-u-v) p0 + u p1 + v p2,
  // so u = x = 0.25, v = y = 0.5.
  Ray ray;
  ray.origin = {0.25f, 0.5f, 0.0f};
  ray.direction = {0, 0, -1};
  Hit hit = accel.intersect(ray);
  ASSERT_TRUE(hit.valid());
  EXPECT_EQ(hit.triangle, 0u);
  EXPECT_NEAR(hit.t, 2.0f, 1e-6);
  EXPECT_NEAR(hit.u, 0.25f, 1e-6);
  EXPECT_NEAR(hit.v, 0.5f, 1e-6);
  SurfacePoint sp = s.surface_point(hit.triangle, hit.u, hit.v);
  EXPECT_NEAR(sp.position.z, -2.0f, 1e-6);

  // t is in units of |direction|: doubling the direction halves t.
  ray.direction = {0, 0, -2};
  EXPECT_NEAR(accel.intersect(ray).t, 1.0f, 1e-6);

  // tnear past A: the next hit is B at t = 4 (unit direction).
  ray.direction = {0, 0, -1};
  ray.tnear = 3.0f;
  hit = accel.intersect(ray);
  ASSERT_TRUE(hit.valid());
  EXPECT_EQ(hit.triangle, 1u);
  EXPECT_NEAR(hit.t, 4.0f, 1e-6);

  // Outside the triangles (u + v > 1): a miss.
  ray.tnear = 0.0f;
  ray.origin = {0.75f, 0.75f, 0.0f};
  EXPECT_FALSE(accel.intersect(ray).valid());
}

TEST(Accel, OccludedSegments) {
  Scene s = two_triangles();
  Accel accel(s);
  Ray ray;
  ray.origin = {0.25f, 0.25f, 0.0f};
  ray.direction = {0, 0, -1};
  ray.tfar = 1.5f;  // stops before A at t = 2
  EXPECT_FALSE(accel.occluded(ray));
  ray.tfar = 2.5f;
  EXPECT_TRUE(accel.occluded(ray));
  ray.tnear = 2.5f;  // between A and B
  ray.tfar = 3.5f;
  EXPECT_FALSE(accel.occluded(ray));
  ray.direction = {0, 0, 1};  // away from both
  ray.tnear = 0.0f;
  ray.tfar = 100.0f;
  EXPECT_FALSE(accel.occluded(ray));
}

TEST(Accel, SharesLoaderBuffersAndAnswersConcurrently) {
  Scene s = load_gltf(std::string(DOFCACHE_SOURCE_DIR) + "/scenes/cornell_box.gltf");
  EXPECT_GT(s.mesh.positions.capacity(), s.mesh.positions.size());  // room for Embree's padding
  Accel accel(s);
  const Camera& cam = s.cameras[0];
  glm::vec3 eye(cam.camera_to_world[3]);
  glm::vec3 forward = -glm::vec3(cam.camera_to_world[2]);
  std::atomic<int> misses{0};
  auto work = [&](int seed) {
    for (int i = 0; i < 2000; ++i) {
      float x = ((i * 37 + seed) % 100) / 100.0f - 0.5f,
            y = ((i * 53 + seed) % 100) / 100.0f - 0.5f;
      Ray ray;
      ray.origin = eye;
      ray.direction = forward + glm::vec3(0.4f * x, 0.4f * y, 0.0f);
      Hit hit = accel.intersect(ray);
      if (!hit.valid() || !(hit.t > 0.8f)) ++misses;  // the box is at least 0.85 m away
    }
  };
  std::thread a(work, 1), b(work, 2);
  a.join();
  b.join();
  EXPECT_EQ(misses.load(), 0);  // every ray into the open box hits something
}

TEST(Accel, EmptyMeshBuildsAndMisses) {
  Scene s;
  Accel accel(s);
  Ray ray;
  EXPECT_FALSE(accel.intersect(ray).valid());
  EXPECT_FALSE(accel.occluded(ray));
}

// Opaque and cut-out triangles side by side, in long runs of one kind (Embree geometries sharing
// the scene's index buffer) or alternating (many short runs: the indices are copied into two
// geometries): either way each hit names its scene triangle and the cut-out ones are not hit.
TEST(Accel, HitsNameTheSceneTriangleWhetherRunsAreSharedOrCopied) {
  for (std::size_t run_length : {std::size_t{16}, std::size_t{1}}) {  // 4 runs; 64 runs
    Scene s;
    const std::size_t n = 64;
    for (std::size_t i = 0; i < n; ++i) {
      const float x = static_cast<float>(i);
      const auto first = static_cast<std::uint32_t>(s.mesh.positions.size());
      s.mesh.positions.insert(s.mesh.positions.end(),
                              {{x, 0, -2}, {x + 0.8f, 0, -2}, {x, 0.8f, -2}});
      s.mesh.triangles.push_back({first, first + 1, first + 2});
      s.mesh.triangle_material.push_back((i / run_length) % 2 == 0 ? 0 : 1);
      s.mesh.triangle_object.push_back(0);
    }
    s.mesh.normals.assign(s.mesh.positions.size(), glm::vec3(0, 0, 1));
    s.materials.resize(2);
    s.materials[1].alpha_mode = AlphaMode::Mask;
    s.materials[1].base_color.a = 0.0f;  // cut out everywhere
    Accel accel(s);
    for (std::size_t i = 0; i < n; ++i) {
      Ray ray;
      ray.origin = {static_cast<float>(i) + 0.2f, 0.2f, 0.0f};
      ray.direction = {0, 0, -1};
      const Hit hit = accel.intersect(ray);
      if (s.mesh.triangle_material[i] == 0) {
        ASSERT_TRUE(hit.valid()) << "run length " << run_length << ", triangle " << i;
        EXPECT_EQ(hit.triangle, i) << "run length " << run_length;
        EXPECT_NEAR(hit.u, 0.25f, 1e-5f);
      } else {
        EXPECT_FALSE(hit.valid()) << "run length " << run_length << ", triangle " << i;
        EXPECT_FALSE(accel.occluded(ray)) << "run length " << run_length << ", triangle " << i;
      }
    }
  }
}

}  // namespace
}  // namespace dofcache::scene
