// Cache traces survive a write/read round trip bit for bit; bad files give one clear error.
#include "dofcache/cache/trace.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <fstream>

#include "dofcache/core/error.h"

namespace dofcache::cache {
namespace {

std::string temp_path(const char* name) {
  return ::testing::TempDir() + "/" + name;
}

CacheTrace small_trace() {
  CacheTrace t;
  t.options.max_normal_angle_deg = 17.5f;
  t.options.min_samples = 3;
  t.options.reject_in_front = false;
  t.options.front_tolerance = 0.125f;
  t.options.footprint_squeeze = 0.5f;
  t.options.footprint_axis = {0.0f, 1.0f, 0.0f};
  t.options.camera_position = {1.0f, 2.0f, 3.0f};
  t.options.camera_forward = {0.0f, 0.0f, -1.0f};
  t.options.floor_per_depth = 0.001f;
  for (int p = 0; p < 3; ++p) {
    TracePass pass;
    for (int i = 0; i < 5 + p; ++i)
      pass.lookups.push_back({{0.1f * i, -1.5f * p, 3.0f}, {0.0f, 0.6f, 0.8f}});
    for (int i = 0; i < 2 * p; ++i) {
      CacheSample s;
      s.position = {1.0f * i, 2.0f, -3.0f * p};
      s.normal = {0.0f, 0.0f, 1.0f};
      s.value = {0.5f, 1e-3f * i, 7.0f};
      s.radius = 0.01f * (i + 1);
      s.frame = static_cast<std::uint32_t>(p);
      pass.inserts.push_back(s);
    }
    t.passes.push_back(pass);
  }
  t.passes.push_back({{{{9.0f, 9.0f, 9.0f}, {1.0f, 0.0f, 0.0f}}}, {}});  // lookups only
  return t;
}

TEST(Trace, RoundTrip) {
  CacheTrace t = small_trace();
  std::string path = temp_path("roundtrip.dctrace");
  write_trace(path, t);
  CacheTrace r = read_trace(path);
  EXPECT_EQ(r.options.max_normal_angle_deg, 17.5f);
  EXPECT_EQ(r.options.min_samples, 3);
  EXPECT_FALSE(r.options.reject_in_front);
  EXPECT_EQ(r.options.front_tolerance, 0.125f);
  EXPECT_EQ(r.options.footprint_squeeze, 0.5f);
  EXPECT_EQ(r.options.footprint_axis, glm::vec3(0.0f, 1.0f, 0.0f));
  EXPECT_EQ(r.options.camera_position, glm::vec3(1.0f, 2.0f, 3.0f));
  EXPECT_EQ(r.options.camera_forward, glm::vec3(0.0f, 0.0f, -1.0f));
  EXPECT_EQ(r.options.floor_per_depth, 0.001f);
  ASSERT_EQ(r.passes.size(), t.passes.size());
  EXPECT_EQ(r.lookup_count(), t.lookup_count());
  EXPECT_EQ(r.insert_count(), t.insert_count());
  for (std::size_t p = 0; p < t.passes.size(); ++p) {
    ASSERT_EQ(r.passes[p].lookups.size(), t.passes[p].lookups.size());
    ASSERT_EQ(r.passes[p].inserts.size(), t.passes[p].inserts.size());
    for (std::size_t i = 0; i < t.passes[p].lookups.size(); ++i)
      EXPECT_EQ(std::memcmp(&r.passes[p].lookups[i], &t.passes[p].lookups[i], sizeof(TraceLookup)),
                0);
    for (std::size_t i = 0; i < t.passes[p].inserts.size(); ++i)
      EXPECT_EQ(std::memcmp(&r.passes[p].inserts[i], &t.passes[p].inserts[i], sizeof(CacheSample)),
                0);
  }
  // Header 72 bytes; records: 4 lookup (8 + 24 n), 4 insert (8 + 44 n; the last one empty),
  // end 8.
  std::ifstream f(path, std::ios::binary | std::ios::ate);
  EXPECT_EQ(static_cast<std::size_t>(f.tellg()),
            72 + 4 * 8 + 24 * t.lookup_count() + 4 * 8 + 44 * t.insert_count() + 8);
  std::remove(path.c_str());
}

TEST(Trace, StreamingWriterMatchesWriteTrace) {
  CacheTrace t = small_trace();
  std::string a = temp_path("a.dctrace"), b = temp_path("b.dctrace");
  write_trace(a, t);
  {
    TraceWriter w(b, t.options);
    for (const TracePass& p : t.passes) {
      w.add_lookups(p.lookups);
      w.add_inserts(p.inserts);
    }
  }  // the destructor closes
  CacheTrace ra = read_trace(a), rb = read_trace(b);
  EXPECT_EQ(ra.lookup_count(), rb.lookup_count());
  EXPECT_EQ(ra.insert_count(), rb.insert_count());
  std::remove(a.c_str());
  std::remove(b.c_str());
}

// A version-1 trace (before the anisotropic footprint) is read with a round one.
TEST(Trace, VersionOneIsReadWithARoundFootprint) {
  const std::string path = temp_path("v1.dctrace");
  {
    std::ofstream f(path, std::ios::binary);
    auto put = [&](const auto& v) { f.write(reinterpret_cast<const char*>(&v), sizeof v); };
    f.write("DOFCTRC", 8);
    put(std::uint32_t{1});
    put(20.0f), put(std::int32_t{2}), put(std::uint32_t{1}), put(0.05f);
    put(std::uint32_t{1}), put(std::uint32_t{1});  // one lookup
    for (float v : {0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 1.0f}) put(v);
    put(std::uint32_t{0}), put(std::uint32_t{0});
  }
  const CacheTrace r = read_trace(path);
  EXPECT_EQ(r.options.max_normal_angle_deg, 20.0f);
  EXPECT_EQ(r.options.min_samples, 2);
  EXPECT_FALSE(r.options.anisotropic());
  EXPECT_EQ(r.lookup_count(), 1u);
  std::remove(path.c_str());
  // A footprint that is no squeeze is refused.
  CacheTrace bad = small_trace();
  bad.options.footprint_squeeze = 2.0f;
  write_trace(path, bad);
  EXPECT_THROW(read_trace(path), Error);
  std::remove(path.c_str());
}

TEST(Trace, BadFilesThrow) {
  EXPECT_THROW(read_trace(temp_path("missing.dctrace")), Error);
  std::string path = temp_path("bad.dctrace");
  {
    std::ofstream f(path, std::ios::binary);
    f << "not a trace at all, just text";
  }
  EXPECT_THROW(read_trace(path), Error);
  write_trace(path, small_trace());
  {  // truncate
    std::ifstream in(path, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), {});
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size() - 30));
  }
  try {
    read_trace(path);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("truncated"), std::string::npos);
  }
  std::remove(path.c_str());
}

}  // namespace
}  // namespace dofcache::cache
