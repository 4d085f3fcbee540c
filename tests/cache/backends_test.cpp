// Both cache backends against a brute-force reference and against each other: identical accepted
// sets and bit-identical interpolated values, over random samples whose radii span more than three
// orders of magnitude, whatever the insertion order or the number of threads.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <thread>
#include <vector>

#include <glm/geometric.hpp>

#include "dofcache/cache/octree_cache.h"
#include "dofcache/cache/radiance_cache.h"
#include "dofcache/cache/tile_buffer.h"
#include "dofcache/cache/vdb_cache.h"
#include "dofcache/cache/weights.h"
#include "dofcache/core/error.h"
#include "dofcache/core/rng.h"

namespace dofcache::cache {
namespace {

struct Query {
  glm::vec3 p, n;
};

glm::vec3 random_unit(Rng& rng) {
  float z = 2.0f * rng.uniform() - 1.0f, a = 6.2831853f * rng.uniform();
  float s = std::sqrt(std::max(0.0f, 1.0f - z * z));
  return {s * std::cos(a), s * std::sin(a), z};
}

// n tilted by up to max_deg degrees in a random direction.
glm::vec3 perturb(glm::vec3 n, float max_deg, Rng& rng) {
  glm::vec3 t = glm::normalize(glm::cross(n, std::abs(n.x) < 0.9f ? glm::vec3(1, 0, 0)
                                                                     : glm::vec3(0, 1, 0)));
  glm::vec3 b = glm::cross(n, t);
  float a = max_deg * 3.14159265f / 180.0f * rng.uniform(), phi = 6.2831853f * rng.uniform();
  return glm::normalize(std::cos(a) * n + std::sin(a) * (std::cos(phi) * t + std::sin(phi) * b));
}

// A point on one of a few surfaces (a floor, a wall, two spheres) with its normal.
Query surface_point(Rng& rng) {
  switch (rng.uniform_index(4)) {
    case 0:
      return {{20.0f * rng.uniform() - 10.0f, 0.0f, -30.0f * rng.uniform()}, {0, 1, 0}};
    case 1:
      return {{20.0f * rng.uniform() - 10.0f, 8.0f * rng.uniform(), -30.0f}, {0, 0, 1}};
    case 2: {
      glm::vec3 d = random_unit(rng);
      return {glm::vec3(-2.0f, 1.0f, -4.0f) + 1.0f * d, d};
    }
    default: {
      glm::vec3 d = random_unit(rng);
      return {glm::vec3(3.0f, 2.0f, -12.0f) + 2.0f * d, d};
    }
  }
}

// Samples with radii log-uniform over [1e-4, 1] m (four orders of magnitude), their normals
// tilted up to 20 degrees and positions lifted up to 2% of the radius off the surface (noise as
// real shading normals and hit points have), values spread over six orders of magnitude.
std::vector<CacheSample> random_samples(std::size_t count, std::uint64_t seed) {
  Rng rng(seed);
  std::vector<CacheSample> out(count);
  for (CacheSample& s : out) {
    Query q = surface_point(rng);
    s.radius = std::pow(10.0f, -4.0f + 4.0f * rng.uniform());
    s.position = q.p + q.n * (0.02f * s.radius * (2.0f * rng.uniform() - 1.0f));
    s.normal = perturb(q.n, 20.0f, rng);
    s.value = glm::vec3(std::pow(10.0f, 6.0f * rng.uniform() - 3.0f), rng.uniform(),
                        rng.uniform());
    s.frame = rng.uniform_index(4);
  }
  return out;
}

// Queries near samples (so that many succeed) and anywhere on the surfaces.
std::vector<Query> random_queries(const std::vector<CacheSample>& samples, std::size_t count,
                                  std::uint64_t seed) {
  Rng rng(seed);
  std::vector<Query> out(count);
  for (Query& q : out) {
    if (rng.uniform() < 0.75f) {
      const CacheSample& s = samples[rng.uniform_index(static_cast<std::uint32_t>(samples.size()))];
      glm::vec3 offset = random_unit(rng) * (1.3f * s.radius * rng.uniform());
      q.p = s.position + offset;
      q.n = perturb(s.normal, 30.0f, rng);
    } else {
      q = surface_point(rng);
      q.n = perturb(q.n, 10.0f, rng);
    }
  }
  return out;
}

// The reference: every sample, the library's own acceptance test and sum.
bool brute_force(const std::vector<CacheSample>& samples, glm::vec3 p, glm::vec3 n,
                 const LookupOptions& options, LookupResult* out) {
  SampleTest test(p, n, options);
  WeightedSum sum;
  for (const CacheSample& s : samples) {
    float w = test.weight(s.position, s.radius, s.normal);
    if (w > 0.0f) sum.add(s.id, w, s.value);
  }
  return sum.finish(options.min_samples, out);
}

bool bit_equal(const LookupResult& a, const LookupResult& b) {
  return a.count == b.count && std::memcmp(&a.value, &b.value, sizeof a.value) == 0 &&
         std::memcmp(&a.weight_sum, &b.weight_sum, sizeof a.weight_sum) == 0;
}

std::vector<std::unique_ptr<RadianceCache>> both_backends() {
  std::vector<std::unique_ptr<RadianceCache>> caches;
  caches.push_back(make_radiance_cache("octree"));
  caches.push_back(make_radiance_cache("vdb"));
  return caches;
}

TEST(Factory, NamesAndErrors) {
  EXPECT_EQ(make_radiance_cache("none"), nullptr);
  EXPECT_EQ(make_radiance_cache("octree")->name(), "octree");
  EXPECT_EQ(make_radiance_cache("vdb")->name(), "vdb");
  try {
    make_radiance_cache("kdtree");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("kdtree"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("none, octree, vdb"), std::string::npos);
  }
  EXPECT_THROW(make_vdb_radiance_cache({3.0f}), Error);
}

// One check of backend names for every user (render, sequence, persistent cache, farm plan);
// "none" only where no cache is allowed.
TEST(Factory, OneCheckOfBackendNames) {
  for (const std::string& name : radiance_cache_backends())
    EXPECT_NO_THROW(check_radiance_cache_backend(name, /*allow_none=*/true)) << name;
  EXPECT_NO_THROW(check_radiance_cache_backend("octree", /*allow_none=*/false));
  EXPECT_NO_THROW(check_radiance_cache_backend("vdb", /*allow_none=*/false));
  for (bool allow_none : {true, false}) {
    try {
      check_radiance_cache_backend(allow_none ? "Octree" : "none", allow_none);
      ADD_FAILURE() << "expected an error";
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(allow_none ? "'Octree'" : "'none'"), std::string::npos) << what;
      EXPECT_NE(what.find(allow_none ? "(valid: none, octree, vdb)" : "(valid: octree, vdb)"),
                std::string::npos)
          << what;
    }
  }
}

TEST(Backends, MatchBruteForceAndEachOtherBitForBit) {
  std::vector<CacheSample> batch = random_samples(6000, 1);
  auto caches = both_backends();
  for (auto& c : caches) {
    // Two batches, as two render passes would insert them.
    c->insert({batch.begin(), batch.begin() + 2500});
    c->insert({batch.begin() + 2500, batch.end()});
    ASSERT_EQ(c->size(), batch.size());
  }
  std::vector<CacheSample> stored = caches[0]->samples();
  std::vector<CacheSample> stored_vdb = caches[1]->samples();
  ASSERT_EQ(stored.size(), stored_vdb.size());
  for (std::size_t i = 0; i < stored.size(); ++i) {
    ASSERT_EQ(stored[i].id, i);
    ASSERT_EQ(stored_vdb[i].id, i);
    ASSERT_EQ(std::memcmp(&stored[i], &stored_vdb[i], sizeof(CacheSample)), 0);
  }

  LookupOptions options;
  int hits = 0, multi = 0;
  for (const Query& q : random_queries(batch, 5000, 2)) {
    LookupResult ref, oct, vdb;
    bool ok = brute_force(stored, q.p, q.n, options, &ref);
    ASSERT_EQ(caches[0]->lookup(q.p, q.n, options, &oct), ok);
    ASSERT_EQ(caches[1]->lookup(q.p, q.n, options, &vdb), ok);
    ASSERT_TRUE(bit_equal(ref, oct)) << ref.count << " vs " << oct.count;
    ASSERT_TRUE(bit_equal(ref, vdb)) << ref.count << " vs " << vdb.count;
    hits += ok;
    multi += ref.count > 1;
  }
  // The query mix exercises hits, misses and multi-sample interpolation.
  EXPECT_GT(hits, 1500);
  EXPECT_LT(hits, 4800);
  EXPECT_GT(multi, 300);
}

TEST(Backends, EveryVdbCellScaleMatchesBruteForce) {
  // Voxels 1, 2, 4 and 8 times the radius: a sample copied into 1 to 27 voxels, across leaf
  // nodes; still counted and returned once.
  std::vector<CacheSample> batch = random_samples(4000, 21);
  std::vector<Query> queries = random_queries(batch, 3000, 22);
  auto reference = make_radiance_cache("octree");
  reference->insert({batch.begin(), batch.begin() + 1000});
  reference->insert({batch.begin() + 1000, batch.end()});
  std::vector<CacheSample> stored = reference->samples();
  for (float scale : {1.0f, 2.0f, 4.0f, 8.0f}) {
    auto c = make_vdb_radiance_cache({scale});
    c->insert({batch.begin(), batch.begin() + 1000});
    c->insert({batch.begin() + 1000, batch.end()});
    ASSERT_EQ(c->size(), stored.size()) << scale;
    std::vector<CacheSample> got = c->samples();
    ASSERT_EQ(got.size(), stored.size()) << scale;
    for (std::size_t i = 0; i < got.size(); ++i) {
      ASSERT_EQ(got[i].id, stored[i].id) << scale;
      ASSERT_EQ(got[i].position, stored[i].position) << scale;
      ASSERT_EQ(got[i].radius, stored[i].radius) << scale;
      ASSERT_EQ(got[i].value, stored[i].value) << scale;
    }
    for (const Query& q : queries) {
      LookupResult ref, r;
      bool ok = brute_force(stored, q.p, q.n, {}, &ref);
      ASSERT_EQ(c->lookup(q.p, q.n, {}, &r), ok) << scale;
      ASSERT_TRUE(bit_equal(ref, r)) << scale;
    }
  }
}

// An independent check of the tests themselves, in double precision from the equations: no
// lookup accepts (weights) a sample that fails the distance, normal, in-front or eps test.
TEST(Backends, DenseClusterMatchesBruteForce) {
  // Hundreds of overlapping samples in one voxel: every lookup tests long runs in which most
  // blocks have samples in reach, and accepts more samples than the sum keeps inline.
  Rng rng(31);
  std::vector<CacheSample> batch(1500);
  for (CacheSample& s : batch) {
    s.position = glm::vec3(0.25f, 0.0f, -2.0f) +
                 0.01f * glm::vec3(rng.uniform(), rng.uniform(), rng.uniform());
    s.normal = perturb({0, 1, 0}, 10.0f, rng);
    s.radius = 0.04f + 0.01f * rng.uniform();
    s.value = glm::vec3(rng.uniform(), rng.uniform(), rng.uniform());
  }
  for (auto& c : both_backends()) {
    c->insert({batch.begin(), batch.begin() + 700});
    c->insert({batch.begin() + 700, batch.end()});
    std::vector<CacheSample> stored = c->samples();
    for (int i = 0; i < 200; ++i) {
      glm::vec3 p = glm::vec3(0.25f, 0.0f, -2.0f) +
                    0.06f * glm::vec3(rng.uniform(), rng.uniform(), rng.uniform()) -
                    glm::vec3(0.025f);
      glm::vec3 n = perturb({0, 1, 0}, 10.0f, rng);
      LookupResult ref, r;
      bool ok = brute_force(stored, p, n, {}, &ref);
      ASSERT_EQ(c->lookup(p, n, {}, &r), ok) << c->name();
      ASSERT_TRUE(bit_equal(ref, r)) << c->name() << " " << ref.count << " vs " << r.count;
    }
  }
}

TEST(Backends, NeverWeightAFailingSample) {
  std::vector<CacheSample> batch = random_samples(3000, 3);
  LookupOptions options;
  options.max_normal_angle_deg = 20.0f;
  const double cos_max = std::cos(20.0 * 3.14159265358979 / 180.0);
  for (auto& c : both_backends()) {
    c->insert(batch);
    std::vector<CacheSample> stored = c->samples();
    int checked = 0;
    for (const Query& q : random_queries(batch, 3000, 4)) {
      int count = 0;
      double w_sum = 0.0, v_sum = 0.0;
      bool borderline = false;
      for (const CacheSample& s : stored) {
        glm::dvec3 d = glm::dvec3(q.p) - glm::dvec3(s.position);
        double dist = glm::length(d), c_n = glm::dot(glm::dvec3(q.n), glm::dvec3(s.normal));
        double front = glm::dot(d, glm::dvec3(q.n) + glm::dvec3(s.normal)) / 2.0;
        double eps = dist / (s.radius * c_n);
        // Skip queries where rounding could decide (a sample in reach within 1e-4 of a
        // threshold).
        if (dist < s.radius * (1.0 + 1e-4) &&
            (std::abs(c_n - cos_max) < 1e-4 || std::abs(eps - 1.0) < 1e-4 ||
             std::abs(front + 0.05 * s.radius) < 1e-4 * s.radius))
          borderline = true;
        if (c_n < cos_max || front < -0.05 * s.radius || !(eps < 1.0)) continue;
        double w = (1.0 - eps) * (1.0 - eps);
        ++count;
        w_sum += w;
        v_sum += w * s.value.x;
      }
      if (borderline) continue;
      ++checked;
      LookupResult r;
      c->lookup(q.p, q.n, options, &r);
      ASSERT_EQ(r.count, count) << c->name();
      if (count > 0) {
        EXPECT_NEAR(r.weight_sum, w_sum, 1e-4 * w_sum + 1e-6);
        EXPECT_NEAR(r.value.x, v_sum / w_sum, 1e-4 * (v_sum / w_sum));
      }
    }
    EXPECT_GT(checked, 2500);
  }
}

TEST(Backends, MinSamples) {
  // Three samples covering the origin, a fourth far away.
  std::vector<CacheSample> batch(4);
  for (int i = 0; i < 4; ++i) {
    batch[i].position = glm::vec3(0.1f * i, 0.0f, 0.0f);
    if (i == 3) batch[i].position += glm::vec3(5.0f);
    batch[i].normal = {0, 0, 1};
    batch[i].radius = 0.5f;
    batch[i].value = glm::vec3(static_cast<float>(i));
  }
  for (auto& c : both_backends()) {
    c->insert(batch);
    LookupOptions options;
    LookupResult r;
    for (int m : {1, 2, 3}) {
      options.min_samples = m;
      EXPECT_TRUE(c->lookup({0.05f, 0, 0}, {0, 0, 1}, options, &r)) << c->name() << m;
      EXPECT_EQ(r.count, 3);
    }
    options.min_samples = 4;
    EXPECT_FALSE(c->lookup({0.05f, 0, 0}, {0, 0, 1}, options, &r));
    EXPECT_EQ(r.count, 3);  // still reported
    EXPECT_GT(r.weight_sum, 0.0f);
    options.min_samples = 1;
    EXPECT_FALSE(c->lookup({2.0f, 0, 0}, {0, 0, 1}, options, &r));
    EXPECT_EQ(r.count, 0);
    EXPECT_EQ(r.value, glm::vec3(0.0f));
  }
}

TEST(Backends, ReportAcceptedIdsInIncreasingOrder) {
  std::vector<CacheSample> batch = random_samples(3000, 23);
  auto caches = both_backends();
  for (auto& c : caches) c->insert(batch);
  std::vector<CacheSample> stored = caches[0]->samples();
  LookupOptions options;
  options.min_samples = 3;  // ids are reported for failed lookups too
  for (const Query& q : random_queries(batch, 2000, 24)) {
    std::vector<std::uint32_t> expected;
    SampleTest test(q.p, q.n, options);
    for (const CacheSample& s : stored)
      if (test.weight(s.position, s.radius, s.normal) > 0.0f) expected.push_back(s.id);
    for (auto& c : caches) {
      std::vector<std::uint32_t> ids = {12345};  // appended to, not replaced
      LookupResult r;
      r.accepted_ids = &ids;
      c->lookup(q.p, q.n, options, &r);
      ASSERT_EQ(r.accepted_ids, &ids);
      ASSERT_EQ(ids.size(), expected.size() + 1) << c->name();
      ASSERT_TRUE(std::equal(expected.begin(), expected.end(), ids.begin() + 1)) << c->name();
      ASSERT_EQ(r.count, static_cast<int>(expected.size()));
    }
  }
}

TEST(Backends, InsertionOrderWithinABatchDoesNotMatter) {
  std::vector<CacheSample> batch = random_samples(3000, 5);
  std::vector<CacheSample> shuffled = batch;
  Rng rng(6);
  for (std::size_t i = shuffled.size() - 1; i > 0; --i)
    std::swap(shuffled[i], shuffled[rng.uniform_index(static_cast<std::uint32_t>(i + 1))]);
  for (const char* backend : {"octree", "vdb"}) {
    auto a = make_radiance_cache(backend), b = make_radiance_cache(backend);
    a->insert(batch);
    b->insert(shuffled);
    std::vector<CacheSample> sa = a->samples(), sb = b->samples();
    ASSERT_EQ(std::memcmp(sa.data(), sb.data(), sa.size() * sizeof(CacheSample)), 0);
    for (const Query& q : random_queries(batch, 2000, 7)) {
      LookupResult ra, rb;
      ASSERT_EQ(a->lookup(q.p, q.n, {}, &ra), b->lookup(q.p, q.n, {}, &rb));
      ASSERT_TRUE(bit_equal(ra, rb)) << backend;
    }
  }
}

TEST(Backends, MemoryGrowsWithSize) {
  std::vector<CacheSample> batch = random_samples(8000, 8);
  for (auto& c : both_backends()) {
    EXPECT_EQ(c->memory_bytes(), 0u) << c->name();
    std::size_t prev = 0;
    for (std::size_t i = 0; i < batch.size(); i += 2000) {
      c->insert({batch.begin() + i, batch.begin() + i + 2000});
      std::size_t bytes = c->memory_bytes();
      EXPECT_GT(bytes, prev) << c->name();
      // At least the samples themselves (48 bytes each).
      EXPECT_GE(bytes, c->size() * 48) << c->name();
      prev = bytes;
    }
    c->clear();
    EXPECT_EQ(c->size(), 0u);
    EXPECT_EQ(c->memory_bytes(), 0u);
    EXPECT_EQ(c->next_id(), 0u);
  }
}

TEST(Backends, ConcurrentLookupsMatchSingleThreaded) {
  std::vector<CacheSample> batch = random_samples(5000, 9);
  std::vector<Query> queries = random_queries(batch, 8000, 10);
  for (auto& c : both_backends()) {
    c->insert(batch);
    std::vector<LookupResult> expected(queries.size());
    for (std::size_t i = 0; i < queries.size(); ++i)
      c->lookup(queries[i].p, queries[i].n, {}, &expected[i]);
    // Every thread does every query, in a different order, several times.
    constexpr int kThreads = 4;
    std::vector<int> mismatches(kThreads, 0);
    std::vector<std::thread> threads;
    for (int t = 0; t < kThreads; ++t)
      threads.emplace_back([&, t] {
        for (int round = 0; round < 3; ++round)
          for (std::size_t k = 0; k < queries.size(); ++k) {
            std::size_t i =
                (k * (2 * t + 1) + static_cast<std::size_t>(round) * 977) % queries.size();
            LookupResult r;
            c->lookup(queries[i].p, queries[i].n, {}, &r);
            mismatches[t] += !bit_equal(r, expected[i]);
          }
      });
    for (std::thread& th : threads) th.join();
    for (int t = 0; t < kThreads; ++t) EXPECT_EQ(mismatches[t], 0) << c->name() << " thread " << t;
  }
}

TEST(Backends, AlternatingBetweenManyCachesOnOneThread) {
  // More vdb caches than a thread keeps readers for, each with other samples, read in turn; then
  // one of them changes between lookups. Every answer must still be its own cache's.
  std::vector<CacheSample> batch = random_samples(3000, 25);
  std::vector<Query> queries = random_queries(batch, 600, 26);
  std::vector<std::unique_ptr<RadianceCache>> caches;
  std::vector<std::vector<CacheSample>> stored;
  for (int i = 0; i < 6; ++i) {
    caches.push_back(make_radiance_cache("vdb"));
    caches.back()->insert({batch.begin() + 300 * i, batch.begin() + 300 * i + 1200});
    stored.push_back(caches.back()->samples());
  }
  for (int round = 0; round < 2; ++round) {
    for (const Query& q : queries)
      for (std::size_t i = 0; i < caches.size(); ++i) {
        LookupResult ref, r;
        bool ok = brute_force(stored[i], q.p, q.n, {}, &ref);
        ASSERT_EQ(caches[i]->lookup(q.p, q.n, {}, &r), ok);
        ASSERT_TRUE(bit_equal(ref, r)) << "cache " << i;
      }
    caches[2]->insert({batch.begin(), batch.begin() + 100});
    stored[2] = caches[2]->samples();
  }
}

TEST(Backends, EraseIfAndRestoreKeepIds) {
  std::vector<CacheSample> batch = random_samples(4000, 11);
  std::vector<Query> queries = random_queries(batch, 2000, 12);
  for (const char* backend : {"octree", "vdb"}) {
    auto c = make_radiance_cache(backend);
    c->insert(batch);
    std::size_t removed = c->erase_if([](const CacheSample& s) { return s.id % 3 == 0; });
    EXPECT_EQ(removed, (batch.size() + 2) / 3);
    EXPECT_EQ(c->size(), batch.size() - removed);
    EXPECT_EQ(c->next_id(), batch.size());
    std::vector<CacheSample> kept = c->samples();
    for (const CacheSample& s : kept) EXPECT_NE(s.id % 3, 0u);
    // A cache restored from the saved samples (another backend even) answers bit-identically.
    auto restored = make_radiance_cache(std::string(backend) == "vdb" ? "octree" : "vdb");
    restored->restore(kept);
    EXPECT_EQ(restored->next_id(), kept.back().id + 1);
    for (const Query& q : queries) {
      LookupResult ref, a, b;
      bool ok = brute_force(kept, q.p, q.n, {}, &ref);
      ASSERT_EQ(c->lookup(q.p, q.n, {}, &a), ok);
      ASSERT_EQ(restored->lookup(q.p, q.n, {}, &b), ok);
      ASSERT_TRUE(bit_equal(ref, a));
      ASSERT_TRUE(bit_equal(ref, b));
    }
  }
}

TEST(Backends, WorldSpaceFarFromTheOrigin) {
  // A scene placed kilometres away with millimetre samples: the octree grows by re-rooting and
  // the vdb keeps its coordinates in range; both still match the reference.
  std::vector<CacheSample> batch = random_samples(2000, 13);
  for (CacheSample& s : batch) s.position += glm::vec3(5000.0f, -3000.0f, 1000.0f);
  std::vector<Query> queries = random_queries(batch, 2000, 14);
  auto caches = both_backends();
  for (auto& c : caches) c->insert(batch);
  std::vector<CacheSample> stored = caches[0]->samples();
  int hits = 0;
  for (const Query& q : queries) {
    LookupResult ref, a, b;
    bool ok = brute_force(stored, q.p, q.n, {}, &ref);
    ASSERT_EQ(caches[0]->lookup(q.p, q.n, {}, &a), ok);
    ASSERT_EQ(caches[1]->lookup(q.p, q.n, {}, &b), ok);
    ASSERT_TRUE(bit_equal(ref, a));
    ASSERT_TRUE(bit_equal(ref, b));
    hits += ok;
  }
  EXPECT_GT(hits, 500);
}

TEST(TileSampleBuffer, SameSemanticsAsTheCache) {
  std::vector<CacheSample> batch = random_samples(400, 15);
  TileSampleBuffer tile;
  for (const CacheSample& s : batch) tile.add(s);
  ASSERT_EQ(tile.size(), batch.size());
  std::vector<CacheSample> local = tile.samples();  // ids = creation order
  for (std::size_t i = 0; i < local.size(); ++i) ASSERT_EQ(local[i].id, i);
  auto cache = make_radiance_cache("vdb");
  cache->insert(batch);
  int hits = 0;
  for (const Query& q : random_queries(batch, 3000, 16)) {
    LookupResult ref, t, c;
    bool ok = brute_force(local, q.p, q.n, {}, &ref);
    ASSERT_EQ(tile.lookup(q.p, q.n, {}, &t), ok);
    ASSERT_TRUE(bit_equal(ref, t));
    // The cache sums the same samples in another id order: same set, same value up to rounding.
    ASSERT_EQ(cache->lookup(q.p, q.n, {}, &c), ok);
    ASSERT_EQ(c.count, t.count);
    EXPECT_NEAR(c.value.x, t.value.x, 1e-5f * std::abs(t.value.x));
    hits += ok;
  }
  EXPECT_GT(hits, 1000);
  std::vector<CacheSample> merged;
  tile.append_to(&merged);
  EXPECT_EQ(merged.size(), batch.size());
  tile.clear();
  EXPECT_TRUE(tile.empty());
  EXPECT_FALSE(tile.lookup(batch[0].position, batch[0].normal, {}, nullptr));
}

}  // namespace
}  // namespace dofcache::cache
