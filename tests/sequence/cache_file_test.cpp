// Cache files: a save/load round trip is bit-exact and renders identically; files made for
// another scene or other shading settings are refused; damaged files are refused, never crash.
#include <gtest/gtest.h>

#include "scratch_dir.h"

#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include <sys/resource.h>

#include "dofcache/core/error.h"
#include "dofcache/render/renderer.h"
#include "dofcache/render/setup.h"
#include "dofcache/scene/accel.h"
#include "dofcache/sequence/cache_file.h"

using namespace dofcache;
using namespace dofcache::sequence;
namespace fs = std::filesystem;

namespace {

class CacheFileTest : public dofcache::testing::ScratchDirTest {};

std::vector<cache::SampleRecord> random_records(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<cache::SampleRecord> out;
  for (std::size_t i = 0; i < n; ++i) {
    cache::SampleRecord r;
    cache::CacheSample& s = r.sample;
    // Positions of very different magnitudes: they must come back bit for bit.
    float scale = (i % 3 == 0) ? 1e-3f : (i % 3 == 1) ? 1.0f : 250.0f;
    s.position = glm::vec3(u(rng), u(rng), u(rng)) * scale;
    s.normal = glm::normalize(glm::vec3(u(rng), u(rng), u(rng)) + glm::vec3(0.0f, 0.0f, 2.0f));
    s.value = glm::vec3(u(rng) + 1.0f, u(rng) + 1.0f, 7.0f * (u(rng) + 1.0f));
    s.radius = 1e-3f + 0.01f * (u(rng) + 1.0f);
    r.origin.radius = s.radius * 2.0f;
    r.origin.view_radius = s.radius * 0.5f;
    r.origin.footprint = s.radius * 0.25f;
    s.id = static_cast<std::uint32_t>(3 * i + 7);
    s.frame = static_cast<std::uint32_t>(i % 5);
    r.last_used = static_cast<std::int32_t>(i % 7) - 1;
    out.push_back(r);
  }
  return out;
}

bool same_bits(const cache::SampleRecord& a, const cache::SampleRecord& b) {
  const cache::CacheSample &x = a.sample, &y = b.sample;
  return std::memcmp(&x.position, &y.position, sizeof x.position) == 0 &&
         std::memcmp(&x.normal, &y.normal, sizeof x.normal) == 0 &&
         std::memcmp(&x.value, &y.value, sizeof x.value) == 0 &&
         std::memcmp(&x.radius, &y.radius, 4) == 0 && x.id == y.id && x.frame == y.frame &&
         std::memcmp(&a.origin.radius, &b.origin.radius, 4) == 0 &&
         std::memcmp(&a.origin.view_radius, &b.origin.view_radius, 4) == 0 &&
         std::memcmp(&a.origin.footprint, &b.origin.footprint, 4) == 0 &&
         a.last_used == b.last_used;
}

CacheFile sample_file(std::size_t n) {
  CacheFile f;
  f.identity = {0x0123456789abcdefULL, 2, 8, 1, 3};
  f.scene_source = "test scene";
  f.min_factor = 0.75;
  f.records = random_records(n, 42);
  return f;
}

TEST_F(CacheFileTest, RoundTripIsBitExact) {
  CacheFile f = sample_file(3000);
  f.checkpoint = SequenceCheckpoint{0xfeedbeefcafe1234ULL, 3, 17};
  write_cache_file(path("c.vdb"), f);
  CacheFile g = read_cache_file(path("c.vdb"));
  EXPECT_EQ(g.identity, f.identity);
  EXPECT_EQ(g.scene_source, f.scene_source);
  EXPECT_DOUBLE_EQ(g.min_factor, 0.75);
  ASSERT_TRUE(g.checkpoint.has_value());
  EXPECT_EQ(g.checkpoint->sequence_key, 0xfeedbeefcafe1234ULL);
  EXPECT_EQ(g.checkpoint->first_frame, 3);
  EXPECT_EQ(g.checkpoint->frame, 17);
  ASSERT_EQ(g.records.size(), f.records.size());
  for (std::size_t i = 0; i < f.records.size(); ++i)
    ASSERT_TRUE(same_bits(g.records[i], f.records[i])) << "sample " << i;

  // An empty cache, without a checkpoint.
  CacheFile empty;
  empty.identity = f.identity;
  write_cache_file(path("empty.vdb"), empty);
  CacheFile e = read_cache_file(path("empty.vdb"));
  EXPECT_TRUE(e.records.empty());
  EXPECT_FALSE(e.checkpoint.has_value());
  // Only the target files remain (writes go through a temporary file).
  std::size_t files = 0;
  for (const auto& entry : fs::directory_iterator(dir_)) files += entry.is_regular_file();
  EXPECT_EQ(files, 2u);
}

TEST_F(CacheFileTest, SavedCacheRendersIdentically) {
  scene::Scene scene = render::load_scene("");
  scene::Accel accel(scene);
  const scene::Camera& camera = scene.cameras[0];
  render::RenderSettings s;
  s.width = 32;
  s.height = 24;
  s.spp = 4;
  s.threads = 2;
  s.shading.light_samples = 1;
  s.shading.gather_rays = 4;
  s.cache.sample_quality = 1;
  s.lens = render::resolve_lens(scene, accel, camera, {}).lens;
  s.progress = Progress::Display::Never;

  cache::PersistentCache original("vdb", cache::ReusePolicy{});
  render::ThinLensCamera cam = render::make_camera(camera, s);
  s.cache.cache = original.begin_frame(0, cam.frame_camera());
  s.cache.frame = 0;
  render::render(scene, accel, camera, s);
  original.end_frame();
  ASSERT_GT(original.size(), 100u);

  CacheFile f;
  f.identity = cache_identity(scene, s);
  f.records = original.records();
  write_cache_file(path("saved.vdb"), f);
  CacheFile g = read_cache_file(path("saved.vdb"));
  check_cache_identity(g, cache_identity(scene, s), "saved.vdb");
  cache::PersistentCache loaded("octree", cache::ReusePolicy{});  // any backend renders the same
  loaded.assign(g.records);

  // The next frame: a refocus and another seed, rendered from each cache.
  s.lens.focus_distance *= 1.1;
  s.seed = 7;
  s.cache.frame = 1;
  cam = render::make_camera(camera, s);
  s.cache.cache = original.begin_frame(1, cam.frame_camera());
  render::RenderOutput a = render::render(scene, accel, camera, s);
  original.end_frame();
  s.cache.cache = loaded.begin_frame(1, cam.frame_camera());
  render::RenderOutput b = render::render(scene, accel, camera, s);
  loaded.end_frame();
  ASSERT_GT(a.stats.cache_hits, 0u);
  EXPECT_EQ(a.color.data(), b.color.data());
  EXPECT_EQ(a.stats.cache_hits, b.stats.cache_hits);
  ASSERT_EQ(original.size(), loaded.size());
  for (std::size_t i = 0; i < original.size(); ++i)
    ASSERT_TRUE(same_bits(original.records()[i], loaded.records()[i])) << i;
}

TEST_F(CacheFileTest, RefusesOtherSceneOrShading) {
  CacheFile f = sample_file(10);
  write_cache_file(path("c.vdb"), f);
  CacheFile g = read_cache_file(path("c.vdb"));
  auto message = [&](CacheIdentity expected) {
    try {
      check_cache_identity(g, expected, "c.vdb");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  CacheIdentity other = f.identity;
  other.scene_hash ^= 1;
  EXPECT_NE(message(other).find("another scene"), std::string::npos) << message(other);
  other = f.identity;
  other.gather_rays = 32;
  EXPECT_NE(message(other).find("--gather-rays 8"), std::string::npos) << message(other);
  other = f.identity;
  other.sample_quality = 4;
  EXPECT_NE(message(other).find("--cache-sample-quality"), std::string::npos);
  other = f.identity;
  other.environment_hash = 0xfeedULL;  // the cache was made without an environment
  EXPECT_NE(message(other).find("another environment light"), std::string::npos)
      << message(other);
  EXPECT_EQ(message(f.identity), "accepted");
}

// A file records the lens it was made through; a lens of another design is refused in one line
// naming both, unless any lens is accepted; files from before lenses were recorded are accepted.
TEST_F(CacheFileTest, RecordsTheLensAndRefusesAnotherDesign) {
  CacheFile f = sample_file(5);
  lens::ApertureShape six;
  six.blades = 6;
  f.lens = lens::lens_identity(lens::ThinLens(0.05, 2.8, 3.0, six));
  write_cache_file(path("lens.vdb"), f);
  const CacheFile g = read_cache_file(path("lens.vdb"));
  EXPECT_EQ(g.lens.design, f.lens.design);
  EXPECT_EQ(g.lens.description, f.lens.description);

  auto message = [&](const CacheFile& file, const lens::LensIdentity& expected, bool any) {
    try {
      check_cache_lens(file, expected, "lens.vdb", any);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  // Refocused, zoomed, stopped down: the same lens.
  EXPECT_EQ(message(g, lens::lens_identity(lens::ThinLens(0.035, 8.0, 1.5, six)), false),
            "accepted");
  const lens::LensIdentity round = lens::lens_identity(lens::ThinLens(0.05, 2.8, 3.0));
  const std::string refused = message(g, round, false);
  EXPECT_EQ(refused.find('\n'), std::string::npos);
  EXPECT_EQ(refused.rfind("lens.vdb: the cache was made through another lens", 0), 0u) << refused;
  EXPECT_NE(refused.find("6 blades"), std::string::npos) << refused;
  EXPECT_NE(refused.find("aperture round"), std::string::npos) << refused;
  EXPECT_NE(refused.find("--cache-any-lens"), std::string::npos) << refused;
  EXPECT_EQ(message(g, round, true), "accepted");

  // Written without a lens (as before lenses were recorded): nothing to compare.
  write_cache_file(path("old.vdb"), sample_file(5));
  const CacheFile old = read_cache_file(path("old.vdb"));
  EXPECT_EQ(old.lens.design, 0u);
  EXPECT_EQ(message(old, round, false), "accepted");
}

TEST_F(CacheFileTest, EnvironmentIsPartOfTheIdentity) {
  CacheFile f = sample_file(4);
  f.identity.environment_hash = 0x00000000cafef00dULL;
  write_cache_file(path("env.vdb"), f);
  const CacheFile g = read_cache_file(path("env.vdb"));
  EXPECT_EQ(g.identity.environment_hash, 0x00000000cafef00dULL);
  EXPECT_TRUE(g.identity == f.identity);

  // What a render computes: the environment's own content hash, or 0 without one.
  scene::Scene scene;
  render::RenderSettings s;
  EXPECT_EQ(cache_identity(scene, s).environment_hash, 0u);
  s.shading.environment = std::make_shared<render::Environment>(
      render::Environment::constant(glm::vec3(0.5f)));
  const std::uint64_t grey = cache_identity(scene, s).environment_hash;
  EXPECT_EQ(grey, s.shading.environment->content_hash());
  EXPECT_NE(grey, 0u);
  s.shading.environment = std::make_shared<render::Environment>(
      render::Environment::constant(glm::vec3(0.25f)));
  EXPECT_NE(cache_identity(scene, s).environment_hash, grey);
  EXPECT_THROW(check_cache_identity(g, cache_identity(scene, s), "env.vdb"), Error);
}

TEST_F(CacheFileTest, RefusesDamagedFiles) {
  CacheFile f = sample_file(500);
  write_cache_file(path("good.vdb"), f);
  std::string good = dofcache::testing::slurp(path("good.vdb"));
  auto write_raw = [&](const std::string& name, const std::string& bytes) {
    std::ofstream(path(name), std::ios::binary) << bytes;
    return path(name);
  };
  auto refused = [&](const std::string& file) {
    try {
      read_cache_file(file);
    } catch (const Error& e) {
      std::string what = e.what();
      EXPECT_EQ(what.find('\n'), std::string::npos) << what;  // one line
      EXPECT_NE(what.find(file), std::string::npos) << what;  // names the file
      return true;
    }
    return false;
  };
  EXPECT_TRUE(refused(path("missing.vdb")));
  EXPECT_TRUE(refused(write_raw("empty.vdb", "")));
  EXPECT_TRUE(refused(write_raw("text.vdb", "this is not a cache file\n")));
  for (std::size_t cut : {std::size_t{1}, std::size_t{8}, std::size_t{24}, std::size_t{25},
                          good.size() / 2, good.size() - 1})
    EXPECT_TRUE(refused(write_raw("cut.vdb", good.substr(0, good.size() - cut)))) << cut;
  for (std::size_t at = 0; at < good.size(); at += good.size() / 40 + 1) {
    std::string bad = good;
    bad[at] = static_cast<char>(bad[at] ^ 0x5a);
    EXPECT_TRUE(refused(write_raw("flip.vdb", bad))) << "byte " << at;
  }
  // Damage that passes the trailer (a sealed file whose content is wrong) reaches OpenVDB's
  // readers, and is still refused cleanly. (Only a deliberately crafted file gets this far: the
  // checksum catches accidental damage first. Some crafted headers make OpenVDB read for seconds
  // before it gives up, so the test stays with quick cases.)
  const std::string payload = good.substr(0, good.size() - 24);
  auto sealed = [&](const std::string& name, const std::string& bytes) {
    write_raw(name, bytes);
    append_cache_file_trailer(path(name));
    return path(name);
  };
  EXPECT_TRUE(refused(sealed("garbage.vdb", std::string(4096, '\x7f'))));
  EXPECT_TRUE(refused(sealed("half.vdb", payload.substr(0, payload.size() / 2))));
  std::string magic = payload;
  magic[0] = static_cast<char>(magic[0] ^ 1);  // OpenVDB's magic number
  EXPECT_TRUE(refused(sealed("magic.vdb", magic)));
  // And the good file still reads.
  EXPECT_EQ(read_cache_file(path("good.vdb")).records.size(), 500u);
}

// A file's declared sample count is checked against a limit before anything is read for it,
// and nothing is reserved for what the metadata claims, only for the points the grid holds.
TEST_F(CacheFileTest, DeclaredSampleCountIsBounded) {
  write_cache_file(path("ten.vdb"), sample_file(10));
  EXPECT_EQ(read_cache_file(path("ten.vdb"), 10).records.size(), 10u);
  try {
    read_cache_file(path("ten.vdb"), 9);
    ADD_FAILURE() << "accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("declares 10 samples, more than the limit of 9"),
              std::string::npos) << e.what();
  }
}

// Forged files (re-sealed with a valid trailer, which accidental damage never produces) whose
// declared lengths exceed the file: OpenVDB 10 allocated and filled what they declared (a 1.8 GB
// string; 16 million attribute name pairs, 1 GB) before noticing the damage. The file's layout is
// walked before OpenVDB reads it, so they are refused in one line without that memory.
TEST_F(CacheFileTest, ForgedLengthsAreRefusedBeforeOpenVdbAllocatesThem) {
  write_cache_file(path("good.vdb"), sample_file(20));
  std::string good = dofcache::testing::slurp(path("good.vdb"));
  good.resize(good.size() - 24);  // the OpenVDB part, without the trailer
  auto u32 = [](std::uint32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); };
  auto u64 = [](std::uint64_t v) { return std::string(reinterpret_cast<const char*>(&v), 8); };
  struct Forgery {
    std::string name;
    std::string anchor;   // bytes around the field (their first occurrence)
    std::size_t offset;   // of the field in `anchor`
    std::string value;    // the forged field
    std::string message;  // expected in the error
  };
  const std::vector<Forgery> forgeries = {
      // The scene's source string, in the file metadata.
      {"scene-string", "dofcache.scene" + u32(6) + "string", 24, u32(1862270976),
       "file metadata 'dofcache.scene' needs 1862270976 bytes"},
      // The grid's name, in its descriptor after the grid count.
      {"grid-name", u32(1) + u32(7) + "samples", 4, u32(2000000000),
       "grid name needs 2000000000 bytes"},
      // The number of point attributes, in the first leaf's buffers.
      {"attribute-count", "\x01" + u64(10) + u32(5) + "vec3s", 1, u64(std::uint64_t{1} << 24),
       "16777216 point attributes, dofcache writes 10"},
  };
  for (const Forgery& f : forgeries) {
    std::string bytes = good;
    const std::size_t at = bytes.find(f.anchor);
    ASSERT_NE(at, std::string::npos) << f.name;
    bytes.replace(at + f.offset, f.value.size(), f.value);
    const std::string file = path(f.name + ".vdb");
    std::ofstream(file, std::ios::binary) << bytes;
    append_cache_file_trailer(file);

    rusage before{}, after{};
    getrusage(RUSAGE_SELF, &before);
    try {
      read_cache_file(file);
      ADD_FAILURE() << f.name << ": accepted";
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_EQ(what.rfind(file + ": ", 0), 0u) << what;
      EXPECT_NE(what.find(f.message), std::string::npos) << f.name << ": " << what;
      EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    }
    getrusage(RUSAGE_SELF, &after);
    EXPECT_LT(after.ru_maxrss - before.ru_maxrss, 256 * 1024) << f.name << ": peak RSS grew (KB)";
  }
}

// A forged blosc header in an attribute page (found by fuzzing): blosc believes the compressed
// size its header states over the buffer OpenVDB hands it, and read past the page's buffer
// (AddressSanitizer: heap-buffer-overflow in LZ4_decompress_safe). The walk checks each blosc
// header against the page sizes around it.
TEST_F(CacheFileTest, ForgedBloscHeaderIsRefused) {
  constexpr std::size_t n = 3000;  // last_used, the last attribute: 12000 bytes, one blosc page
  write_cache_file(path("good.vdb"), sample_file(n));
  std::string bytes = dofcache::testing::slurp(path("good.vdb"));
  bytes.resize(bytes.size() - 24);  // the OpenVDB part, without the trailer
  // The last page is the file's end: a blosc header (u32 uncompressed size at +4, u32 compressed
  // size at +12) whose compressed size reaches exactly to the end.
  std::size_t at = std::string::npos;
  for (std::size_t o = bytes.size() - 16; o > 0 && at == std::string::npos; --o) {
    std::uint32_t nbytes, cbytes;
    std::memcpy(&nbytes, bytes.data() + o + 4, 4);
    std::memcpy(&cbytes, bytes.data() + o + 12, 4);
    if (nbytes == 4 * n && cbytes == bytes.size() - o) at = o;
  }
  ASSERT_NE(at, std::string::npos) << "no blosc page at the end";
  const std::uint32_t forged = 1 << 20;
  std::memcpy(bytes.data() + at + 12, &forged, 4);
  const std::string file = path("forged.vdb");
  std::ofstream(file, std::ios::binary) << bytes;
  append_cache_file_trailer(file);
  try {
    read_cache_file(file);
    ADD_FAILURE() << "accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("attribute page: blosc header does not match"),
              std::string::npos)
        << e.what();
  }
}

// Found by fuzzing: an attribute array's flags without "constant stride" make OpenVDB take the
// array for one value in all, and indexing it by point read past its end.
TEST_F(CacheFileTest, AttributeArrayFlagsAreChecked) {
  write_cache_file(path("good.vdb"), sample_file(20));
  std::string bytes = dofcache::testing::slurp(path("good.vdb"));
  bytes.resize(bytes.size() - 24);
  // The descriptor's last attribute name (sorted), its position, no groups, no metadata; then
  // the first array's metadata: u64 bytes, u8 flags.
  const std::string last = std::string("\x0b\0\0\0", 4) + "view_radius";
  const std::size_t at = bytes.find(last);
  ASSERT_NE(at, std::string::npos);
  const std::size_t flags = at + last.size() + 8 + 8 + 4 + 8;
  ASSERT_EQ(bytes[flags], '\x08');
  bytes[flags] = '\x12';
  const std::string file = path("flags.vdb");
  std::ofstream(file, std::ios::binary) << bytes;
  append_cache_file_trailer(file);
  try {
    read_cache_file(file);
    ADD_FAILURE() << "accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("attribute array flags 18"), std::string::npos)
        << e.what();
  }
}

// The layout walk accepts every file the writer makes: empty, with and without a checkpoint, and
// many samples in many leaves and pages (P's 1.4 MB span two pages).
TEST_F(CacheFileTest, LayoutWalkAcceptsWhatTheWriterMakes) {
  for (std::size_t n : {std::size_t{0}, std::size_t{3}, std::size_t{120000}}) {
    CacheFile f = sample_file(n);
    if (n == 3) f.checkpoint = SequenceCheckpoint{0xfedcba9876543210ULL, 4, 9};
    write_cache_file(path("file.vdb"), f);
    CacheFile back = read_cache_file(path("file.vdb"));
    EXPECT_EQ(back.records.size(), n);
    EXPECT_EQ(back.checkpoint.has_value(), n == 3);
  }
}

}  // namespace
