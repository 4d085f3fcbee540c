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
#include "dofcache/sequence/checkpoint_journal.h"
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

  // Frames 0..last of dir_/a and dir_/b ("####.exr") are identical.
  void expect_same_frames(const std::string& a, const std::string& b, int last = 5) const {
    for (int f = 0; f <= last; ++f) {
      std::string name = frame_path("####.exr", f);
      EXPECT_EQ(pixels((dir_ / a / name).string()), pixels((dir_ / b / name).string()))
          << "frame " << f;
    }
  }

  std::string journal_of(const std::string& pattern) const {
    return checkpoint_journal_path(default_checkpoint_path((dir_ / pattern).string()));
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
  // From the full checkpoint of frame 0 and the journal's records of frames 1 and 2.
  EXPECT_EQ(sum.journal_records_replayed, 2);
  ASSERT_EQ(notices.size(), 1u);
  EXPECT_NE(notices[0].find("resuming after frame 2"), std::string::npos) << notices[0];
  EXPECT_NE(notices[0].find("2 journal records"), std::string::npos) << notices[0];
  expect_same_frames("cut", "full");
  // The checkpoints agree as well: the same full checkpoint, journals of the same records.
  CacheFile a = read_cache_file(default_checkpoint_path((dir_ / "full/####.exr").string()));
  CacheFile b = read_cache_file(default_checkpoint_path((dir_ / "cut/####.exr").string()));
  EXPECT_EQ(a.checkpoint->frame, 0);
  EXPECT_EQ(records_hash(a.records), records_hash(b.records));
  CheckpointJournal ja = read_checkpoint_journal(journal_of("full/####.exr"));
  CheckpointJournal jb = read_checkpoint_journal(journal_of("cut/####.exr"));
  ASSERT_EQ(ja.records.size(), 5u);
  ASSERT_EQ(jb.records.size(), 5u);
  EXPECT_EQ(ja.records.back().frame, 5);
  for (std::size_t k = 0; k < 5; ++k)
    EXPECT_EQ(ja.records[k].state_hash, jb.records[k].state_hash) << k;
}

// Each frame's checkpoint is a journal record much smaller than the full checkpoint, and the
// cache the journal replays to is the one the run ended with.
TEST_F(SequenceTest, JournalRecordsCostWhatTheFrameChanged) {
  std::vector<FrameReport> reports;
  SequenceSettings s = settings(CacheMode::Persistent, "j/####.exr");
  SequenceRenderer r(*scene_, *accel_, frames(), s);
  r.run([&](const FrameReport& f) { reports.push_back(f); });
  ASSERT_EQ(reports.size(), 6u);
  EXPECT_TRUE(reports[0].checkpoint_full);
  const std::string base = default_checkpoint_path(s.output);
  EXPECT_EQ(reports[0].checkpoint_bytes, fs::file_size(base) + kJournalHeaderBytes);
  std::uint64_t journal = kJournalHeaderBytes;
  for (std::size_t i = 1; i < reports.size(); ++i) {
    EXPECT_FALSE(reports[i].checkpoint_full) << i;
    EXPECT_LT(reports[i].checkpoint_bytes * 4, fs::file_size(base)) << i;
    // 56 bytes of record and frame data, 64 per new sample, at least one bit per kept sample.
    EXPECT_GE(reports[i].checkpoint_bytes, 56 + 64 * reports[i].cache.inserted) << i;
    journal += reports[i].checkpoint_bytes;
  }
  EXPECT_EQ(fs::file_size(journal_of("j/####.exr")), journal);
  CheckpointJournal j = read_checkpoint_journal(journal_of("j/####.exr"));
  ASSERT_EQ(j.records.size(), 5u);
  EXPECT_EQ(j.records.back().state_hash, state_hash(r.cache()->records()));

  // Ratio 0: the full checkpoint after every frame, no journal.
  s = settings(CacheMode::Persistent, "full/####.exr");
  s.checkpoint_journal_ratio = 0.0;
  SequenceRenderer(*scene_, *accel_, frames(0, 2), s).run([](const FrameReport& f) {
    EXPECT_TRUE(f.checkpoint_full) << f.frame;
  });
  EXPECT_FALSE(fs::exists(journal_of("full/####.exr")));
  const CacheFile full = read_cache_file(default_checkpoint_path(s.output));
  EXPECT_EQ(full.checkpoint->frame, 2);
  EXPECT_EQ(full.lens.description, lens::describe_lens(frames(0, 2).back().lens));
}

// A run killed while appending frame 3's record: the record is cut short, the journal is used up
// to frame 2 and frame 3 is rendered again, identically; its new record replaces the cut one.
TEST_F(SequenceTest, RecordCutShortIsRenderedAgain) {
  SequenceRenderer(*scene_, *accel_, frames(), settings(CacheMode::Persistent, "full/####.exr"))
      .run();
  SequenceSettings s = settings(CacheMode::Persistent, "cut/####.exr");
  EXPECT_THROW(SequenceRenderer(*scene_, *accel_, frames(), s).run([](const FrameReport& f) {
    if (f.frame == 3) throw Interrupted();
  }),
               Interrupted);
  const std::string journal = journal_of("cut/####.exr");
  fs::resize_file(journal, fs::file_size(journal) - 7);
  std::vector<std::string> notices;
  SequenceSummary sum = SequenceRenderer(*scene_, *accel_, frames(), s)
                            .run({}, [&](const std::string& n) { notices.push_back(n); });
  EXPECT_EQ(sum.resumed_after, 2);
  EXPECT_EQ(sum.rendered, 3);
  ASSERT_EQ(notices.size(), 2u);
  EXPECT_NE(notices[0].find("cut short; resuming after frame 2"), std::string::npos)
      << notices[0];
  expect_same_frames("cut", "full");
  CheckpointJournal j = read_checkpoint_journal(journal);
  EXPECT_TRUE(j.tail.empty()) << j.tail;
  EXPECT_EQ(j.records.size(), 5u);
  EXPECT_EQ(fs::file_size(journal), fs::file_size(journal_of("full/####.exr")));
}

// Damaged bytes in a record end the journal before it; in the header, the journal is not used
// and the run resumes from the full checkpoint alone. Either way one line says so, and the frames
// come out as in an uninterrupted run.
TEST_F(SequenceTest, DamagedJournalIsRefusedInOneLine) {
  SequenceRenderer(*scene_, *accel_, frames(), settings(CacheMode::Persistent, "full/####.exr"))
      .run();
  for (bool in_header : {false, true}) {
    const std::string out = in_header ? "header/####.exr" : "record/####.exr";
    SequenceSettings s = settings(CacheMode::Persistent, out);
    EXPECT_THROW(SequenceRenderer(*scene_, *accel_, frames(), s).run([](const FrameReport& f) {
      if (f.frame == 3) throw Interrupted();
    }),
                 Interrupted);
    const std::string journal = journal_of(out);
    CheckpointJournal before = read_checkpoint_journal(journal);
    ASSERT_EQ(before.records.size(), 3u);
    std::string bytes = dofcache::testing::slurp(journal);
    // The header's frame field, or the middle of frame 2's record.
    std::size_t at = in_header ? 17 : (before.ends[0] + before.ends[1]) / 2;
    bytes[at] ^= 0x04;
    std::ofstream(journal, std::ios::binary | std::ios::trunc) << bytes;
    std::vector<std::string> notices;
    SequenceSummary sum = SequenceRenderer(*scene_, *accel_, frames(), s)
                              .run({}, [&](const std::string& n) { notices.push_back(n); });
    EXPECT_EQ(sum.resumed_after, in_header ? 0 : 1) << out;
    ASSERT_EQ(notices.size(), 2u);
    EXPECT_EQ(notices[0].find('\n'), std::string::npos);
    if (in_header) {
      EXPECT_EQ(notices[0].rfind("not using checkpoint journal " + journal + ": ", 0), 0u)
          << notices[0];
      EXPECT_NE(notices[0].find("damaged"), std::string::npos) << notices[0];
    } else {
      EXPECT_NE(notices[0].find("(checksum mismatch); resuming after frame 1"), std::string::npos)
          << notices[0];
    }
    expect_same_frames(out.substr(0, out.find('/')), "full");
  }
}

// A frame deleted after the full checkpoint: the journal is replayed up to the frame before it.
TEST_F(SequenceTest, JournalStopsAtAMissingFrame) {
  SequenceSettings s = settings(CacheMode::Persistent, "out/####.exr");
  SequenceRenderer(*scene_, *accel_, frames(), s).run();
  std::vector<float> frame4 = pixels((dir_ / "out/0004.exr").string());
  fs::remove(dir_ / "out/0003.exr");
  std::vector<std::string> notices;
  SequenceSummary sum = SequenceRenderer(*scene_, *accel_, frames(), s)
                            .run({}, [&](const std::string& n) { notices.push_back(n); });
  EXPECT_EQ(sum.resumed_after, 2);
  EXPECT_EQ(sum.rendered, 3);
  ASSERT_FALSE(notices.empty());
  EXPECT_NE(notices[0].find("0003.exr) is missing"), std::string::npos) << notices[0];
  EXPECT_EQ(pixels((dir_ / "out/0004.exr").string()), frame4);
}

// Compaction: with a small ratio the journal soon outgrows its share and a frame writes a new
// full checkpoint and an empty journal. A run killed after a later frame resumes from the new
// base and its journal; a run killed between the new base and its journal (the old journal still
// there) does not apply the old journal to the new base.
TEST_F(SequenceTest, CompactionKeepsResumeExact) {
  // The ratio that lets the journal take frame 1's record but not frame 2's as well, from the
  // sizes of a run with the default ratio (no compaction in 6 frames).
  std::vector<std::uint64_t> bytes;
  SequenceRenderer(*scene_, *accel_, frames(0, 2), settings(CacheMode::Persistent, "probe/#.exr"))
      .run([&](const FrameReport& f) { bytes.push_back(f.checkpoint_bytes); });
  const double base = double(bytes[0] - kJournalHeaderBytes);
  const double ratio = (double(kJournalHeaderBytes + bytes[1]) + 0.5 * double(bytes[2])) / base;
  auto with_ratio = [&](const std::string& out) {
    SequenceSettings s = settings(CacheMode::Persistent, out);
    s.checkpoint_journal_ratio = ratio;
    return s;
  };
  std::vector<FrameReport> full;
  SequenceRenderer(*scene_, *accel_, frames(), with_ratio("full/####.exr"))
      .run([&](const FrameReport& f) { full.push_back(f); });
  const int compacted = 2;
  EXPECT_FALSE(full[1].checkpoint_full);
  ASSERT_TRUE(full[compacted].checkpoint_full) << "ratio " << ratio;
  ASSERT_FALSE(full[compacted + 1].checkpoint_full) << "ratio " << ratio;

  // Killed after the frame after the compaction: new base and one journal record.
  SequenceSettings s = with_ratio("after/####.exr");
  EXPECT_THROW(SequenceRenderer(*scene_, *accel_, frames(), s).run([&](const FrameReport& f) {
    if (f.frame == compacted + 1) throw Interrupted();
  }),
               Interrupted);
  SequenceSummary sum = SequenceRenderer(*scene_, *accel_, frames(), s).run();
  EXPECT_EQ(sum.resumed_after, compacted + 1);
  EXPECT_EQ(sum.journal_records_replayed, 1);
  expect_same_frames("after", "full");

  // Killed between the compaction's new base and its new journal.
  s = with_ratio("between/####.exr");
  const std::string journal = journal_of("between/####.exr");
  EXPECT_THROW(SequenceRenderer(*scene_, *accel_, frames(), s).run([&](const FrameReport& f) {
    if (f.frame == compacted - 1) fs::copy_file(journal, journal + ".old");
    if (f.frame == compacted) throw Interrupted();
  }),
               Interrupted);
  fs::rename(journal + ".old", journal);
  std::vector<std::string> notices;
  sum = SequenceRenderer(*scene_, *accel_, frames(), s)
            .run({}, [&](const std::string& n) { notices.push_back(n); });
  EXPECT_EQ(sum.resumed_after, compacted);
  EXPECT_EQ(sum.journal_records_replayed, 0);
  ASSERT_EQ(notices.size(), 2u);
  EXPECT_NE(notices[0].find("extends another checkpoint"), std::string::npos) << notices[0];
  expect_same_frames("between", "full");
}

TEST_F(SequenceTest, KilledBetweenImageAndCheckpoint) {
  SequenceRenderer(*scene_, *accel_, frames(), settings(CacheMode::Persistent, "full/####.exr"))
      .run();
  // Keep the checkpoint as it was after frame 1, let frame 2's image be written, then put the old
  // checkpoint back: the state of a run killed after writing frame 2 but before its checkpoint.
  // Both ways of checkpointing: a journal record (the default) and a full checkpoint (ratio 0).
  for (double ratio : {1.0, 0.0}) {
    const std::string out = ratio > 0.0 ? "cut/####.exr" : "cutfull/####.exr";
    SequenceSettings s = settings(CacheMode::Persistent, out);
    s.checkpoint_journal_ratio = ratio;
    const std::string cp = default_checkpoint_path(s.output);
    const std::string journal = checkpoint_journal_path(cp);
    EXPECT_THROW(SequenceRenderer(*scene_, *accel_, frames(), s).run([&](const FrameReport& f) {
      if (f.frame == 1) {
        fs::copy_file(cp, cp + ".after1");
        if (ratio > 0.0) fs::copy_file(journal, journal + ".after1");
      }
      if (f.frame == 2) throw Interrupted();
    }),
                 Interrupted);
    fs::rename(cp + ".after1", cp);
    if (ratio > 0.0) fs::rename(journal + ".after1", journal);
    SequenceSummary sum = SequenceRenderer(*scene_, *accel_, frames(), s).run();
    EXPECT_EQ(sum.resumed_after, 1) << ratio;
    EXPECT_EQ(sum.rendered, 4) << ratio;  // frame 2 again, identical
    expect_same_frames(out.substr(0, out.find('/')), "full");
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
  // A deleted frame up to the full checkpoint's (frame 0 here; the journal holds the others):
  // start over too.
  fs::remove(dir_ / "out/0000.png");
  SequenceSummary again = SequenceRenderer(*scene_, *accel_, frames(0, 3), s).run();
  EXPECT_EQ(again.rendered, 4);
  EXPECT_TRUE(fs::exists(dir_ / "out/0000.png"));
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
  // It records the lens of the last frame, every parameter of it.
  const FrameSpec last = frames(0, 2).back();
  EXPECT_EQ(saved.lens.design, lens::lens_design(last.lens));
  EXPECT_EQ(saved.lens.description, lens::describe_lens(last.lens));
  EXPECT_NE(saved.lens.description.find("thin lens"), std::string::npos);

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
