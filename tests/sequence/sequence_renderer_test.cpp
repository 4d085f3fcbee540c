// The sequence renderer: frames in order, reuse across frames, frame naming, per-frame seeds, and
// resuming: an interrupted run started again produces exactly the frames of an uninterrupted one.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "dofcache/core/error.h"
#include "dofcache/image/image_io.h"
#include "dofcache/render/setup.h"
#include "dofcache/scene/accel.h"
#include "dofcache/sequence/cache_file.h"
#include "dofcache/sequence/sequence_renderer.h"
#include "scratch_dir.h"

using namespace dofcache;
using namespace dofcache::sequence;
namespace fs = std::filesystem;

namespace {

struct Interrupted : std::runtime_error {
  Interrupted() : std::runtime_error("interrupted") {}
};

class SequenceTest : public dofcache::testing::ScratchDirTest {
 protected:
  static void SetUpTestSuite() {
    scene_ = new scene::Scene(render::load_scene(""));  // the built-in Cornell box
    accel_ = new scene::Accel(*scene_);
  }
  static void TearDownTestSuite() {
    delete accel_;
    delete scene_;
  }
  // Six frames of a slow truck to the right with a focus pull.
  std::vector<FrameSpec> frames(int first = 0, int last = 5) const {
    const scene::Camera& cam = scene_->cameras[0];
    CameraPath path = parse_keyframe_path(R"({"dofcache_camera_path": 1, "keys": [
        {"frame": 0, "position": [0, 0.3, 0.85], "focus_distance": 1.0},
        {"frame": 5, "position": [0.02, 0.3, 0.85], "focus_distance": 1.2}]})",
                                          "test path", cam);
    return plan_frames(*scene_, *accel_, cam, path, 24.0, first, last, {});
  }

  SequenceSettings settings(CacheMode mode, const std::string& out) const {
    SequenceSettings s;
    s.render.width = 24;
    s.render.height = 18;
    s.render.spp = 4;
    s.render.threads = 2;
    s.render.shading.light_samples = 1;
    s.render.shading.gather_rays = 4;
    s.render.cache.sample_quality = 1;
    s.render.progress = Progress::Display::Never;
    s.cache_mode = mode;
    s.evict_after = 3;
    s.output = out.empty() ? "" : (dir_ / out).string();
    return s;
  }

  static std::vector<float> pixels(const std::string& path) {
    return image::read_image(path).data();
  }

  static scene::Scene* scene_;
  static scene::Accel* accel_;
};
scene::Scene* SequenceTest::scene_ = nullptr;
scene::Accel* SequenceTest::accel_ = nullptr;

TEST(SequenceNames, FramePathsAndRanges) {
  EXPECT_EQ(frame_path("frames/####.exr", 7), "frames/0007.exr");
  EXPECT_EQ(frame_path("f_##.png", 123), "f_123.png");
  EXPECT_EQ(frame_path("a#b/x_#.png", 3), "a#b/x_3.png");  // only the file name counts
  EXPECT_THROW(frame_path("frames/out.png", 1), Error);
  EXPECT_THROW(frame_path("frames/#_#.png", 1), Error);
  EXPECT_EQ(default_checkpoint_path("frames/####.exr"), "frames/.####.exr.checkpoint.vdb");
  EXPECT_EQ(parse_frame_range("3-10"), std::make_pair(3, 10));
  EXPECT_EQ(parse_frame_range("4"), std::make_pair(4, 4));
  EXPECT_THROW(parse_frame_range("10-3"), Error);
  EXPECT_THROW(parse_frame_range("-3"), Error);
  EXPECT_THROW(parse_frame_range("1-x"), Error);
  EXPECT_NE(frame_seed(1, 0), frame_seed(1, 1));
  EXPECT_NE(frame_seed(1, 5), frame_seed(2, 5));
}

TEST_F(SequenceTest, PersistentCacheIsReusedAcrossFrames) {
  std::vector<FrameReport> reports;
  SequenceRenderer r(*scene_, *accel_, frames(), settings(CacheMode::Persistent, ""));
  SequenceSummary sum = r.run([&](const FrameReport& f) { reports.push_back(f); });
  ASSERT_EQ(sum.rendered, 6);
  EXPECT_EQ(reports[0].cache.reused, 0u);
  for (std::size_t i = 1; i < reports.size(); ++i) {
    EXPECT_GT(reports[i].cache.reuse_rate(), 0.5) << "frame " << i;
    EXPECT_LT(reports[i].cache.inserted, reports[0].cache.inserted) << "frame " << i;
  }
  // Fresh caches never reuse.
  SequenceRenderer fresh(*scene_, *accel_, frames(), settings(CacheMode::Fresh, ""));
  fresh.run([&](const FrameReport& f) { EXPECT_EQ(f.cache.reused, 0u); });
}

TEST_F(SequenceTest, AnySubsetOfFramesReproduces) {
  for (CacheMode mode : {CacheMode::None, CacheMode::Fresh}) {
    std::vector<std::vector<float>> all, part;
    SequenceRenderer(*scene_, *accel_, frames(), settings(mode, ""))
        .run([&](const FrameReport& f) { all.push_back(f.output.color.data()); });
    SequenceRenderer(*scene_, *accel_, frames(3, 4), settings(mode, ""))
        .run([&](const FrameReport& f) { part.push_back(f.output.color.data()); });
    ASSERT_EQ(part.size(), 2u);
    EXPECT_EQ(part[0], all[3]) << cache_mode_name(mode);
    EXPECT_EQ(part[1], all[4]) << cache_mode_name(mode);
    EXPECT_NE(all[3], all[4]);
  }
}

TEST_F(SequenceTest, ResumedPersistentRunMatchesUninterruptedRun) {
  SequenceRenderer(*scene_, *accel_, frames(), settings(CacheMode::Persistent, "full/####.exr"))
      .run();

  // Interrupted after frame 2 (its image and checkpoint are written; frame 3 never starts).
  SequenceSettings s = settings(CacheMode::Persistent, "cut/####.exr");
  EXPECT_THROW(SequenceRenderer(*scene_, *accel_, frames(), s).run([](const FrameReport& f) {
    if (f.frame == 2) throw Interrupted();
  }),
               Interrupted);
  EXPECT_TRUE(fs::exists(dir_ / "cut/0002.exr"));
  EXPECT_FALSE(fs::exists(dir_ / "cut/0003.exr"));
  std::vector<std::string> notices;
  SequenceSummary sum = SequenceRenderer(*scene_, *accel_, frames(), s)
                            .run({}, [&](const std::string& n) { notices.push_back(n); });
  EXPECT_EQ(sum.resumed_after, 2);
  EXPECT_EQ(sum.skipped, 3);
  EXPECT_EQ(sum.rendered, 3);
  ASSERT_FALSE(notices.empty());
  EXPECT_NE(notices[0].find("resuming after frame 2"), std::string::npos) << notices[0];
  for (int f = 0; f <= 5; ++f) {
    std::string name = frame_path("####.exr", f);
    EXPECT_EQ(pixels((dir_ / "cut" / name).string()), pixels((dir_ / "full" / name).string()))
        << "frame " << f;
  }
  // The checkpoints agree as well.
  CacheFile a = read_cache_file(default_checkpoint_path((dir_ / "full/####.exr").string()));
  CacheFile b = read_cache_file(default_checkpoint_path((dir_ / "cut/####.exr").string()));
  EXPECT_EQ(a.checkpoint->frame, 5);
  EXPECT_EQ(records_hash(a.records), records_hash(b.records));
}

TEST_F(SequenceTest, KilledBetweenImageAndCheckpoint) {
  SequenceRenderer(*scene_, *accel_, frames(), settings(CacheMode::Persistent, "full/####.exr"))
      .run();
  // Keep the checkpoint as it was after frame 1, let frame 2's image be written, then put the old
  // checkpoint back: the state of a run killed after writing frame 2 but before its checkpoint.
  SequenceSettings s = settings(CacheMode::Persistent, "cut/####.exr");
  const std::string cp = default_checkpoint_path(s.output);
  EXPECT_THROW(SequenceRenderer(*scene_, *accel_, frames(), s).run([&](const FrameReport& f) {
    if (f.frame == 1) fs::copy_file(cp, cp + ".after1");
    if (f.frame == 2) throw Interrupted();
  }),
               Interrupted);
  fs::rename(cp + ".after1", cp);
  SequenceSummary sum = SequenceRenderer(*scene_, *accel_, frames(), s).run();
  EXPECT_EQ(sum.resumed_after, 1);
  EXPECT_EQ(sum.rendered, 4);  // frame 2 again, identical
  for (int f = 0; f <= 5; ++f) {
    std::string name = frame_path("####.exr", f);
    EXPECT_EQ(pixels((dir_ / "cut" / name).string()), pixels((dir_ / "full" / name).string()))
        << "frame " << f;
  }
}

TEST_F(SequenceTest, CheckpointOfOtherSettingsIsNotUsed) {
  SequenceSettings s = settings(CacheMode::Persistent, "out/####.png");
  SequenceRenderer(*scene_, *accel_, frames(0, 2), s).run();
  // Extending the range continues from the checkpoint.
  SequenceSummary more = SequenceRenderer(*scene_, *accel_, frames(0, 3), s).run();
  EXPECT_EQ(more.resumed_after, 2);
  EXPECT_EQ(more.rendered, 1);
  // Other settings: the checkpoint does not match, everything is rendered again.
  s.render.spp = 2;
  std::vector<std::string> notices;
  SequenceSummary other = SequenceRenderer(*scene_, *accel_, frames(0, 3), s)
                              .run({}, [&](const std::string& n) { notices.push_back(n); });
  EXPECT_EQ(other.resumed_after, -1);
  EXPECT_EQ(other.rendered, 4);
  ASSERT_FALSE(notices.empty());
  EXPECT_NE(notices[0].find("other settings"), std::string::npos) << notices[0];
  // A deleted frame before the checkpoint: start over too.
  fs::remove(dir_ / "out/0001.png");
  SequenceSummary again = SequenceRenderer(*scene_, *accel_, frames(0, 3), s).run();
  EXPECT_EQ(again.rendered, 4);
  EXPECT_TRUE(fs::exists(dir_ / "out/0001.png"));
}

TEST_F(SequenceTest, IndependentFramesSkipCompleteOnes) {
  SequenceSettings s = settings(CacheMode::Fresh, "fresh/####.exr");
  SequenceRenderer(*scene_, *accel_, frames(0, 3), s).run();
  std::vector<float> frame2 = pixels((dir_ / "fresh/0002.exr").string());
  // A damaged frame is rendered again, complete ones are skipped.
  { std::ofstream((dir_ / "fresh/0002.exr").string()) << "half a file"; }
  SequenceSummary sum = SequenceRenderer(*scene_, *accel_, frames(0, 3), s).run();
  EXPECT_EQ(sum.skipped, 3);
  EXPECT_EQ(sum.rendered, 1);
  EXPECT_EQ(pixels((dir_ / "fresh/0002.exr").string()), frame2);
  s.resume = false;
  EXPECT_EQ(SequenceRenderer(*scene_, *accel_, frames(0, 3), s).run().rendered, 4);
}

TEST_F(SequenceTest, CacheInAndOut) {
  SequenceSettings s = settings(CacheMode::Persistent, "");
  s.cache_out = (dir_ / "out.vdb").string();
  SequenceRenderer first(*scene_, *accel_, frames(0, 2), s);
  first.run();
  CacheFile saved = read_cache_file(s.cache_out);
  EXPECT_EQ(saved.records.size(), first.cache()->size());
  EXPECT_FALSE(saved.checkpoint.has_value());

  // Starting from it, the first frame already reuses.
  SequenceSettings t = settings(CacheMode::Persistent, "");
  t.cache_in = s.cache_out;
  double reuse = 0.0;
  SequenceRenderer(*scene_, *accel_, frames(3, 3), t).run([&](const FrameReport& f) {
    reuse = f.cache.reuse_rate();
  });
  EXPECT_GT(reuse, 0.5);
  // Other shading settings: refused.
  t.render.shading.gather_rays = 8;
  EXPECT_THROW(SequenceRenderer(*scene_, *accel_, frames(3, 3), t).run(), Error);
  // No cache: --cache-in makes no sense.
  t = settings(CacheMode::None, "");
  t.cache_in = s.cache_out;
  EXPECT_THROW(SequenceRenderer(*scene_, *accel_, frames(3, 3), t), Error);
}

}  // namespace
