// `dofcache sequence` end to end: the shipped camera paths render, a run killed midway and started
// again with the same command produces exactly the frames of an uninterrupted run, and cache files
// made for something else, or damaged, are refused with one line.
#include <gtest/gtest.h>

#include "cli_harness.h"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "dofcache/image/image_io.h"

namespace fs = std::filesystem;

namespace {

using dofcache::testing::slurp;

const std::string kScenes = std::string(DOFCACHE_SOURCE_DIR) + "/scenes/";
// Small and quick: every test here renders a handful of tiny frames.
const std::string kDollyFrame0 =
    "sequence " + kScenes + "cornell_box_dolly.gltf --frames 0 --persistent ";
const std::string kQuick = " --width 32 --spp 4 --light-samples 1 --gather-rays 4 "
                           "--cache-sample-quality 1 --threads 2";

class SequenceCli : public dofcache::testing::CliTest {
 protected:
  void expect_one_line_error(const dofcache::testing::CliResult& r, const std::string& needle) {
    CliTest::expect_one_line_error(r, needle, 1);
  }

  std::string at(const std::string& name) const { return path(name); }

  // An uninterrupted run and the same command killed with SIGKILL and run again give the same
  // frames.
  void killed_run_resumes(const std::string& extra, int kill_after);
};

TEST_F(SequenceCli, ShippedPathsRender) {
  dofcache::testing::CliResult dolly = run("sequence " + kScenes + "cornell_box_dolly.gltf --frames 0-2 --persistent " +
                     "-o '" + at("dolly/####.png") + "'" + kQuick);
  ASSERT_EQ(dolly.exit_code, 0) << dolly.err;
  for (const char* f : {"0000.png", "0001.png", "0002.png"})
    EXPECT_TRUE(fs::exists(dir_ / "dolly" / f));
  EXPECT_NE(dolly.out.find("animation 'dolly'"), std::string::npos) << dolly.out;
  EXPECT_NE(dolly.out.find("reuse"), std::string::npos) << dolly.out;

  dofcache::testing::CliResult pull = run("sequence " + kScenes + "cornell_box.gltf --path " + kScenes +
                    "paths/cornell_focus_pull.json --frames 34-35 --cache octree -o '" +
                    at("pull/f##.exr") + "' --stats-json " + at("pull.json") + kQuick);
  ASSERT_EQ(pull.exit_code, 0) << pull.err;
  EXPECT_TRUE(fs::exists(dir_ / "pull/f34.exr"));
  EXPECT_TRUE(fs::exists(dir_ / "pull/f35.exr"));
  // Each frame's camera and lens, as another renderer needs them to render the same view: the
  // path keeps the scene's camera (node translation 0, 0.3, 0.85, no rotation, yfov 0.72) and
  // keys the focus at 1.3 m on frame 35.
  const nlohmann::json stats = nlohmann::json::parse(slurp(dir_ / "pull.json"));
  ASSERT_EQ(stats["per_frame"].size(), 2u);
  const nlohmann::json& f35 = stats["per_frame"][1];
  EXPECT_EQ(f35["frame"], 35);
  EXPECT_NEAR(f35["lens"]["focus_distance"].get<double>(), 1.3, 1e-6);
  EXPECT_NEAR(f35["lens"]["fstop"].get<double>(), 1.4, 1e-6);
  EXPECT_NEAR(f35["camera"]["yfov"].get<double>(), 0.72, 1e-6);
  const std::vector<double> m = f35["camera"]["camera_to_world"].get<std::vector<double>>();
  const std::vector<double> expected = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0.3, 0.85, 1};
  ASSERT_EQ(m.size(), 16u);
  for (int i = 0; i < 16; ++i) EXPECT_NEAR(m[i], expected[i], 1e-6) << i;
}

// `extra`: more options; the run is killed once frame `kill_after` is on disk.
void SequenceCli::killed_run_resumes(const std::string& extra, int kill_after) {
  const std::string args = "sequence " + kScenes + "cornell_box_dolly.gltf --fps 12 --frames 0-9 "
                           "--persistent --width 48 --spp 8 --light-samples 1 --gather-rays 8 -q" +
                           extra;
  ASSERT_EQ(run(args + " -o '" + at("full/####.exr") + "'").exit_code, 0);

  // The same command, killed (SIGKILL: no chance to clean up) once frame `kill_after` is on disk.
  const std::string cut = at("cut/####.exr");
  char waited[16];
  std::snprintf(waited, sizeof waited, "%04d.exr", kill_after);
  pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    std::string cmd = std::string(DOFCACHE_EXE) + " " + args + " -o '" + cut + "' >/dev/null 2>&1";
    ::execl("/bin/sh", "sh", "-c", ("exec " + cmd).c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (!fs::exists(dir_ / "cut" / waited) && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  ::kill(pid, SIGKILL);
  int status = 0;
  ::waitpid(pid, &status, 0);

  dofcache::testing::CliResult resumed = run(args + " -o '" + cut + "'");
  ASSERT_EQ(resumed.exit_code, 0) << resumed.err;
  for (int f = 0; f <= 9; ++f) {
    char name[16];
    std::snprintf(name, sizeof name, "%04d.exr", f);
    ASSERT_TRUE(fs::exists(dir_ / "cut" / name)) << name;
    EXPECT_EQ(dofcache::image::read_image((dir_ / "cut" / name).string()).data(),
              dofcache::image::read_image((dir_ / "full" / name).string()).data())
        << "frame " << f;
  }
  // Nothing half-written is left behind: only frames, the checkpoint and its journal, which
  // holds what the uninterrupted run's does.
  for (const auto& e : fs::directory_iterator(dir_ / "cut")) {
    std::string name = e.path().filename().string();
    EXPECT_TRUE(name.size() == 8 || name == ".####.exr.checkpoint.vdb" ||
                name == ".####.exr.checkpoint.vdb.journal")
        << name;
  }
  for (const char* name : {".####.exr.checkpoint.vdb", ".####.exr.checkpoint.vdb.journal"})
    EXPECT_EQ(fs::exists(dir_ / "cut" / name), fs::exists(dir_ / "full" / name)) << name;
}

// A real lens along the focus pull: described once with the range its field of view breathes
// over, and each frame's statistics record the lens mounted for that frame's focus.
TEST_F(SequenceCli, RealLensBreathesAlongTheFocusPull) {
  dofcache::testing::CliResult r =
      run("sequence " + kScenes + "cornell_box.gltf --path " + kScenes +
          "paths/cornell_focus_pull.json --frames 0-47 --frame-step 47 --lens-file " + kScenes +
          "lenses/double_gauss_50mm.lens -o '" + at("rl/f##.png") + "' --stats-json " +
          at("rl.json") + kQuick);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("double_gauss_50mm.lens (50.4 mm f/2.02), focused per frame"),
            std::string::npos) << r.out;
  const nlohmann::json stats = nlohmann::json::parse(slurp(dir_ / "rl.json"));
  ASSERT_EQ(stats["per_frame"].size(), 2u);
  const nlohmann::json& a = stats["per_frame"][0]["real_lens"];
  const nlohmann::json& b = stats["per_frame"][1]["real_lens"];
  ASSERT_TRUE(a.is_object() && b.is_object()) << stats.dump();
  // The pull racks the focus: the lens moves, and the same film sees another field.
  EXPECT_NE(a["focus_distance_from_sensor"], b["focus_distance_from_sensor"]);
  EXPECT_NE(a["film_distance"], b["film_distance"]);
  EXPECT_NE(a["field_of_view"][1], b["field_of_view"][1]);
}

TEST_F(SequenceCli, KilledRunResumesToTheSameFrames) { killed_run_resumes("", 2); }

// With a small journal ratio the checkpoint is rewritten every few frames: the kill lands around
// a compaction or a journal record after one.
TEST_F(SequenceCli, KilledRunWithCompactionsResumesToTheSameFrames) {
  killed_run_resumes(" --checkpoint-journal 0.15", 6);
}

// Without a journal (a full checkpoint after every frame), as before journals existed.
TEST_F(SequenceCli, KilledRunWithFullCheckpointsResumesToTheSameFrames) {
  killed_run_resumes(" --checkpoint-journal 0", 4);
}

TEST_F(SequenceCli, RefusesForeignAndDamagedCacheFiles) {
  // A cache saved from one scene...
  dofcache::testing::CliResult saved = run(kDollyFrame0 + "-o '" + at("a/####.png") + "' --cache-out " +
                     at("cornell.vdb") + kQuick);
  ASSERT_EQ(saved.exit_code, 0) << saved.err;
  // ... is accepted by the same scene (the dolly file holds the Cornell box's geometry) ...
  dofcache::testing::CliResult same = run("sequence " + kScenes + "cornell_box.gltf --path " + kScenes +
                    "paths/cornell_focus_pull.json --frames 0 --persistent -o '" +
                    at("b/####.png") + "' --cache-in " + at("cornell.vdb") + kQuick);
  EXPECT_EQ(same.exit_code, 0) << same.err;
  EXPECT_NE(same.out.find("loaded"), std::string::npos) << same.out;
  // ... refused by another scene, or with other shading settings.
  std::ofstream(at("still.json"))
      << R"({"dofcache_camera_path": 1, "keys": [{"time": 0, "fstop": 2}]})";
  expect_one_line_error(run("sequence " + kScenes + "color_bars.gltf --path " + at("still.json") +
                            " --persistent -o '" + at("c/####.png") + "' --cache-in " +
                            at("cornell.vdb") + kQuick),
                        "another scene");
  expect_one_line_error(run(kDollyFrame0 + "-o '" +
                            at("d/####.png") + "' --cache-in " + at("cornell.vdb") +
                            " --width 32 --spp 4 --light-samples 1 --gather-rays 16 "
                            "--cache-sample-quality 1"),
                        "--gather-rays");
  // ... refused through a lens of another design, in one line naming both; accepted with
  // --cache-any-lens (the first "same" run above changed focus and f-number: the same lens).
  const std::string pull = "sequence " + kScenes + "cornell_box.gltf --path " + kScenes +
                           "paths/cornell_focus_pull.json --frames 0 --persistent --cache-in " +
                           at("cornell.vdb") + kQuick;
  expect_one_line_error(run(pull + " -o '" + at("f/####.png") + "' --aperture-blades 6"),
                        "another lens (thin lens");
  dofcache::testing::CliResult any =
      run(pull + " -o '" + at("g/####.png") + "' --aperture-blades 6 --cache-any-lens");
  EXPECT_EQ(any.exit_code, 0) << any.err;
  EXPECT_NE(any.out.find("loaded"), std::string::npos) << any.out;
  // Damaged: cut short.
  std::string bytes = slurp(dir_ / "cornell.vdb");
  std::ofstream(at("cut.vdb"), std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  expect_one_line_error(run(kDollyFrame0 + "-o '" +
                            at("e/####.png") + "' --cache-in " + at("cut.vdb") + kQuick),
                        "cut.vdb");
}

TEST_F(SequenceCli, TemporalPassFiltersTheWrittenFramesAndRunsAlone) {
  const std::string dolly = "sequence " + kScenes + "cornell_box_dolly.gltf --frames 0-3 ";
  dofcache::testing::CliResult both =
      run(dolly + "--persistent --temporal 1 -o '" + at("t/####.exr") + "'" + kQuick);
  ASSERT_EQ(both.exit_code, 0) << both.err;
  EXPECT_NE(both.out.find("filtered with 1 frames on each side"), std::string::npos) << both.out;
  EXPECT_NE(both.out.find("4 frames filtered"), std::string::npos) << both.out;
  // The ends have one neighbour, the others two.
  EXPECT_NE(both.out.find("temporal    0"), std::string::npos) << both.out;
  EXPECT_NE(both.out.find("2 neighbours"), std::string::npos) << both.out;
  // The frames keep the raw render with the denoiser's layers; the filtered ones are new files
  // that differ from each frame's own denoised colour.
  const dofcache::image::Image raw = dofcache::image::read_image(at("t/0001.exr"));
  const dofcache::image::Image own =
      dofcache::image::read_channels(at("t/0001.exr"), {"denoised.R", "denoised.G", "denoised.B"});
  const dofcache::image::Image filtered = dofcache::image::read_image(at("t/0001.temporal.exr"));
  ASSERT_EQ(filtered.width(), 32);
  EXPECT_NE(raw.data(), own.data());
  EXPECT_NE(own.data(), filtered.data());

  // --temporal-only renders nothing and filters the same frames to the same images: what the
  // farm's last job runs.
  const std::string mtime_before = std::to_string(fs::last_write_time(at("t/0002.exr"))
                                                      .time_since_epoch().count());
  dofcache::testing::CliResult alone =
      run(dolly + "--persistent --temporal 1 --temporal-only -o '" + at("t/####.exr") +
          "' --temporal-output '" + at("u/####.png") + "'" + kQuick);
  ASSERT_EQ(alone.exit_code, 0) << alone.err;
  EXPECT_EQ(alone.out.find("rendered"), std::string::npos) << alone.out;
  EXPECT_EQ(std::to_string(fs::last_write_time(at("t/0002.exr")).time_since_epoch().count()),
            mtime_before);
  auto again = run(dolly + "--persistent --temporal 1 --temporal-only -o '" + at("t/####.exr") +
                   "' --temporal-output '" + at("v/####.exr") + "'" + kQuick);
  ASSERT_EQ(again.exit_code, 0) << again.err;
  EXPECT_EQ(dofcache::image::read_image(at("v/0003.exr")).data(),
            dofcache::image::read_image(at("t/0003.temporal.exr")).data());
  EXPECT_TRUE(fs::exists(dir_ / "u" / "0000.png"));

  // Frames without the layers, or missing, or not EXR, or not denoised: one line each.
  expect_one_line_error(run(dolly + "--temporal 1 -o '" + at("p/####.png") + "'" + kQuick),
                        "write the frames as EXR");
  expect_one_line_error(
      run(dolly + "--temporal 1 --denoise off -o '" + at("p/####.exr") + "'" + kQuick),
      "drop --denoise off");
  expect_one_line_error(run(dolly + "--temporal-only -o '" + at("t/####.exr") + "'" + kQuick),
                        "--temporal-only needs --temporal");
  expect_one_line_error(run(dolly + "--temporal 1 --temporal-only -o '" + at("none/####.exr") +
                            "'" + kQuick),
                        "temporal filter: frame 0");
  ASSERT_EQ(run(dolly + "--denoise off -o '" + at("r/####.exr") + "'" + kQuick).exit_code, 0);
  expect_one_line_error(run(dolly + "--temporal 1 --temporal-only -o '" + at("r/####.exr") +
                            "'" + kQuick),
                        "denoised.R");
}

TEST_F(SequenceCli, BadOptionsGiveOneLine) {
  const std::string dolly = "sequence " + kScenes + "cornell_box_dolly.gltf";
  expect_one_line_error(run(dolly + " -o '" + at("x.png") + "'"), "'#'");
  expect_one_line_error(run(dolly + " --frames 5-2 -o '" + at("####.png") + "'"), "frame range");
  expect_one_line_error(run(dolly + " --persistent --cache none -o '" + at("####.png") + "'"),
                        "--persistent");
  expect_one_line_error(run("sequence -o '" + at("####.png") + "'"), "--path");
  expect_one_line_error(run(dolly + " --animation walk -o '" + at("####.png") + "'"), "walk");
}

}  // namespace
