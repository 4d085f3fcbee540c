// The persistent cache's frame-to-frame rules: the reuse rule (a sample made out of focus is
// rejected beyond the new, smaller radius once the focus moves onto it, and regrows when the
// focus moves away), usage-based eviction, the memory cap and the reuse statistics.
#include <gtest/gtest.h>

#include <glm/mat4x4.hpp>

#include "dofcache/cache/sample_radius.h"
#include "dofcache/core/error.h"
#include "dofcache/cache/persistent_cache.h"

using namespace dofcache;
using namespace dofcache::cache;

namespace {

// A camera at the origin looking down -Z, 100 mm f/1.4, focused at `focus`.
cache::FrameCamera camera(double focus, glm::vec3 position = glm::vec3(0.0f)) {
  lens::ThinLens l;
  l.focal_length = 0.1;
  l.fstop = 1.4;
  l.focus_distance = focus;
  return {lens::LensImaging{l, 0.7f, 480}, position, glm::vec3(0.0f, 0.0f, -1.0f)};
}

cache::CacheSample sample_at(glm::vec3 p, float radius, std::uint32_t frame) {
  cache::CacheSample s;
  s.position = p;
  s.normal = glm::vec3(0.0f, 0.0f, 1.0f);  // facing the camera
  s.value = glm::vec3(0.25f, 0.5f, 0.75f);
  s.radius = radius;
  s.frame = frame;
  return s;
}

bool hit(const cache::RadianceCache* c, glm::vec3 p) {
  cache::LookupResult r;
  return c->lookup(p, glm::vec3(0.0f, 0.0f, 1.0f), cache::LookupOptions{}, &r);
}

class PersistentCacheTest : public ::testing::TestWithParam<const char*> {};

TEST_P(PersistentCacheTest, SampleMadeOutOfFocusIsRejectedOnceTheFocusMovesOntoIt) {
  cache::ReusePolicy policy;
  policy.evict_after = 0;
  cache::PersistentCache pc(GetParam(), policy);
  const glm::vec3 p(0.0f, 0.0f, -1.0f);  // depth 1 m
  // Frame 0: focused at 3 m, so the point at 1 m is far out of focus and its sample is large.
  cache::FrameCamera blurred = camera(3.0);
  const float r_blurred = static_cast<float>(cache::sample_radius(blurred.imaging, 1.0, 0.5));
  cache::RadianceCache* c = pc.begin_frame(0, blurred);
  c->insert({sample_at(p, r_blurred, 0)});
  cache::FrameCacheStats s0 = pc.end_frame();
  EXPECT_EQ(s0.inserted, 1u);

  // Frame 1, same lens: the sample serves lookups across its whole (large) radius.
  cache::FrameCamera focused = camera(1.0);
  const float r_focused = static_cast<float>(cache::sample_radius(focused.imaging, 1.0, 0.5));
  ASSERT_LT(10.0f * r_focused, r_blurred);  // in focus: half a pixel footprint
  const glm::vec3 beyond = p + glm::vec3(3.0f * r_focused, 0.0f, 0.0f);
  const glm::vec3 within = p + glm::vec3(0.5f * r_focused, 0.0f, 0.0f);
  c = pc.begin_frame(1, blurred);
  EXPECT_TRUE(hit(c, beyond));
  pc.end_frame();

  // Frame 2: the focus is pulled onto the point. The sample may only be used within the radius a
  // sample made now would get: rejected at three radii, accepted at half a radius.
  c = pc.begin_frame(2, focused);
  EXPECT_FALSE(hit(c, beyond));
  EXPECT_TRUE(hit(c, within));
  cache::FrameCacheStats s2 = pc.end_frame();
  EXPECT_EQ(s2.shrunk, 1u);
  ASSERT_EQ(pc.size(), 1u);
  EXPECT_FLOAT_EQ(pc.records()[0].sample.radius, r_focused);
  EXPECT_FLOAT_EQ(pc.records()[0].origin.radius, r_blurred);

  // Frame 3: focus back at 3 m: the sample regrows, but not beyond the radius it was made with.
  c = pc.begin_frame(3, blurred);
  EXPECT_TRUE(hit(c, beyond));
  cache::FrameCacheStats s3 = pc.end_frame();
  EXPECT_EQ(s3.grown, 1u);
  EXPECT_FLOAT_EQ(pc.records()[0].sample.radius, r_blurred);

  // A sample behind the camera keeps its radius (the frame cannot see it).
  cache::FrameCamera turned = camera(1.0, glm::vec3(0.0f, 0.0f, -3.0f));
  pc.begin_frame(4, turned);
  pc.end_frame();
  EXPECT_FLOAT_EQ(pc.records()[0].sample.radius, r_blurred);
}

TEST_P(PersistentCacheTest, CountsReuseAndEvictsUnusedSamples) {
  cache::ReusePolicy policy;
  policy.evict_after = 2;
  cache::PersistentCache pc(GetParam(), policy);
  cache::FrameCamera cam = camera(1.0);
  const float r = static_cast<float>(cache::sample_radius(cam.imaging, 1.0, 0.5));
  const glm::vec3 a(0.0f, 0.0f, -1.0f), b(0.05f, 0.0f, -1.0f);
  cache::RadianceCache* c = pc.begin_frame(10, cam);
  c->insert({sample_at(a, r, 10), sample_at(b, r, 10)});
  EXPECT_TRUE(hit(c, a));  // served by a sample of this very frame: a hit, not a reuse
  cache::FrameCacheStats s = pc.end_frame();
  EXPECT_EQ(s.lookups, 1u);
  EXPECT_EQ(s.hits, 1u);
  EXPECT_EQ(s.reused, 0u);

  for (int f = 11; f <= 12; ++f) {  // only `a` is looked up
    c = pc.begin_frame(f, cam);
    EXPECT_TRUE(hit(c, a));
    EXPECT_FALSE(hit(c, a + glm::vec3(0.02f, 0.0f, 0.0f)));  // between the two: a miss
    s = pc.end_frame();
    EXPECT_EQ(s.lookups, 2u);
    EXPECT_EQ(s.reused, 1u);
    EXPECT_DOUBLE_EQ(s.reuse_rate(), 0.5);
    EXPECT_EQ(s.used, 1u);
  }
  // `b` was last used (made) in frame 10 and unused in 11 and 12: evicted after frame 12.
  EXPECT_EQ(s.evicted_unused, 1u);
  ASSERT_EQ(pc.size(), 1u);
  EXPECT_EQ(pc.records()[0].sample.position, a);
  EXPECT_EQ(pc.records()[0].last_used, 12);
}

TEST_P(PersistentCacheTest, MemoryCapEvictsLeastRecentlyUsedFirst) {
  cache::FrameCamera cam = camera(1.0);
  const float r = static_cast<float>(cache::sample_radius(cam.imaging, 1.0, 0.5));
  std::vector<cache::CacheSample> grid;
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 40; ++j)
      grid.push_back(sample_at(glm::vec3(-0.2f + 0.01f * i, -0.2f + 0.01f * j, -1.0f), r, 0));

  // Measure the full cache, then cap at 60% of it.
  std::size_t full;
  {
    cache::PersistentCache probe(GetParam(), cache::ReusePolicy{});
    probe.begin_frame(0, cam)->insert(grid);
    full = probe.end_frame().memory_bytes;
  }
  cache::ReusePolicy policy;
  policy.evict_after = 0;
  policy.memory_limit = full * 6 / 10;
  cache::PersistentCache pc(GetParam(), policy);
  pc.begin_frame(0, cam)->insert(grid);
  cache::FrameCacheStats s = pc.end_frame();
  EXPECT_GT(s.evicted_memory, 0u);
  EXPECT_LE(s.memory_bytes, policy.memory_limit);
  EXPECT_GT(s.memory_bytes, policy.memory_limit * 3 / 4);  // keeps about as many as fit
  // All were made in frame 0: the oldest ids go first, the newest stay.
  const std::size_t kept = pc.size();
  EXPECT_EQ(pc.records().back().sample.id, grid.size() - 1);

  // Frame 1 uses every other surviving sample; frame 2 adds a new batch: the cap then evicts
  // the samples unused in frame 1 before any used one.
  cache::RadianceCache* c = pc.begin_frame(1, cam);
  std::size_t used = 0;
  for (std::size_t i = 0; i < pc.records().size(); i += 2)
    used += hit(c, pc.records()[i].sample.position);
  EXPECT_EQ(used, (kept + 1) / 2);
  pc.end_frame();
  ASSERT_GT(used, 0u) << kept << " kept of " << grid.size();
  c = pc.begin_frame(2, cam);
  std::vector<cache::CacheSample> more;
  for (int i = 0; i < 20; ++i)
    more.push_back(sample_at(glm::vec3(0.3f + 0.01f * i, 0.0f, -1.0f), r, 2));
  c->insert(more);
  s = pc.end_frame();
  EXPECT_LE(s.memory_bytes, policy.memory_limit);
  std::size_t used_left = 0, new_left = 0;
  for (const cache::SampleRecord& rec : pc.records()) {
    used_left += rec.last_used == 1;
    new_left += rec.last_used == 2;
  }
  EXPECT_EQ(new_left, more.size());  // the newest are the most recently used
  EXPECT_EQ(used_left, std::min(used, pc.size() - new_left));
  EXPECT_LE(pc.size(), kept + more.size());
}

INSTANTIATE_TEST_SUITE_P(Backends, PersistentCacheTest, ::testing::Values("octree", "vdb"));

TEST(PersistentCache, RefusesBadBackendAndDuplicateIds) {
  EXPECT_THROW(cache::PersistentCache("none", cache::ReusePolicy{}), Error);
  cache::PersistentCache pc("vdb", cache::ReusePolicy{});
  cache::SampleRecord r;
  r.sample = sample_at(glm::vec3(0.0f), 0.1f, 0);
  r.origin.radius = 0.1f;
  EXPECT_THROW(pc.assign({r, r}), Error);
}

TEST(PersistentCache, RecordsTheRadiusOriginUnderTheRenderersRule) {
  // The persistent cache is given the renderer's radius settings, and records each new sample's
  // origin under them: a min factor other than the default shows in the recorded view radius.
  cache::FrameCamera cam = camera(1.0);
  cache::RadiusSettings rule;
  rule.min_factor = 2.0;
  cache::PersistentCache pc("vdb", cache::ReusePolicy{}, rule);
  cache::RadianceCache* c = pc.begin_frame(0, cam);
  const float view = static_cast<float>(cache::sample_radius(cam.imaging, 1.0, 2.0));
  c->insert({sample_at(glm::vec3(0.0f, 0.0f, -1.0f), 3.0f * view, 0)});
  pc.end_frame();
  ASSERT_EQ(pc.size(), 1u);
  const cache::RadiusOrigin& o = pc.records()[0].origin;
  EXPECT_FLOAT_EQ(o.view_radius, view);
  EXPECT_FLOAT_EQ(o.radius, 3.0f * view);
  EXPECT_FLOAT_EQ(o.footprint, static_cast<float>(cam.imaging.pixel_footprint(1.0)));
  EXPECT_TRUE(o.widened());
  // The next frame, seen from twice as close, keeps the widening scaled by the footprint.
  cache::FrameCamera closer = camera(0.5, glm::vec3(0.0f, 0.0f, -0.5f));
  pc.begin_frame(1, closer);
  EXPECT_NEAR(pc.records()[0].sample.radius, 1.5f * view, 1e-3f * view);
  pc.end_frame();
  rule.min_factor = -1.0;
  EXPECT_THROW(cache::PersistentCache("vdb", cache::ReusePolicy{}, rule), Error);
}

}  // namespace
