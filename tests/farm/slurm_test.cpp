// Submitting a plan: the sbatch calls and their dependency chain, against a stand-in for sbatch;
// resubmission of only what is missing; running commands and reading job ids.
#include <gtest/gtest.h>

#include "scratch_dir.h"

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>

#include "dofcache/core/error.h"
#include "dofcache/farm/slurm.h"
#include "dofcache/image/image_io.h"
#include "dofcache/sequence/cache_file.h"

using namespace dofcache;
using namespace dofcache::farm;
namespace fs = std::filesystem;

namespace {

// Answers like `sbatch --parsable`: job ids 100, 101, ... and records every call.
struct FakeSbatch {
  std::vector<std::vector<std::string>> calls;
  int next_id = 100;
  int exit_code = 0;
  std::string err;
  CommandResult operator()(const std::vector<std::string>& argv) {
    calls.push_back(argv);
    if (exit_code != 0 && err.size()) return {exit_code, "", err};
    return {exit_code, std::to_string(next_id++) + ";cluster\n", ""};
  }
};

bool has(const std::vector<std::string>& argv, const std::string& arg) {
  return std::find(argv.begin(), argv.end(), arg) != argv.end();
}

class SubmitTest : public dofcache::testing::ScratchDirTest {
 protected:
  void SetUp() override {
    ScratchDirTest::SetUp();
    fs::create_directories(dir_ / "f");
  }

  FarmPlan plan(int max_running = 0) const {
    FarmSettings s;
    s.dofcache = "/usr/bin/dofcache";
    s.work_dir = (dir_ / "work").string();
    s.run_dir = dir_.string();
    s.request.scene = "scene.gltf";
    s.request.cache = "vdb";
    s.request.sequence.persistent = true;
    s.first = 0;
    s.last = 5;
    s.chunk = 2;  // chunks 0-1, 2-3, 4-5
    s.output = (dir_ / "f" / "####.png").string();
    s.width = 8;
    s.height = 6;
    s.cache = "vdb";
    s.carry = true;
    s.slurm.max_running = max_running;
    FarmPlan p(s);
    p.write();
    return p;
  }

  void write_frame(int f) const {
    image::write_image((dir_ / "f" / ("000" + std::to_string(f) + ".png")).string(),
                       image::Image(8, 6, 3, 0.5f));
  }

};

TEST(JobId, FromParsableOutput) {
  EXPECT_EQ(parse_job_id("123\n"), "123");
  EXPECT_EQ(parse_job_id("4567;cluster\n"), "4567");
  EXPECT_THROW(parse_job_id(""), Error);
  EXPECT_THROW(parse_job_id("Submitted batch job 5\n"), Error);
}

TEST_F(SubmitTest, FirstSubmissionChainsWarmRenderAndVerify) {
  FarmPlan p = plan();
  FakeSbatch sbatch;
  Submission sub = submit(p, {}, std::ref(sbatch));
  ASSERT_EQ(sbatch.calls.size(), 3u);
  EXPECT_EQ(sub.warm_job, "100");
  EXPECT_EQ(sub.render_job, "101");
  EXPECT_EQ(sub.verify_job, "102");
  EXPECT_EQ(sub.chunks, (std::vector<int>{0, 1, 2}));

  const auto& warm = sbatch.calls[0];
  EXPECT_EQ(warm.front(), "sbatch");
  EXPECT_TRUE(has(warm, "--parsable"));
  EXPECT_EQ(warm.back(), p.script_file("warm"));

  const auto& render = sbatch.calls[1];
  EXPECT_TRUE(has(render, "--array=0-2"));
  EXPECT_TRUE(has(render, "--dependency=afterok:100"));
  EXPECT_EQ(render.back(), p.script_file("render"));

  const auto& verify = sbatch.calls[2];
  EXPECT_TRUE(has(verify, "--dependency=afterany:101")) << "verify must run even if tasks fail";
  EXPECT_FALSE(has(verify, "--wait"));
  EXPECT_EQ(verify.back(), p.script_file("verify"));
}

TEST_F(SubmitTest, ResubmissionRendersOnlyChunksWithMissingFramesAndKeepsTheWarmCache) {
  FarmPlan p = plan(2);
  // A warm cache from the first submission.
  sequence::CacheFile warm;
  sequence::write_cache_file(p.warm_cache_file(), warm);
  ASSERT_TRUE(warm_cache_ready(p));
  for (int f : {0, 1, 2, 4, 5}) write_frame(f);  // frame 3 lost

  FakeSbatch sbatch;
  SubmitOptions opts;
  opts.sbatch = "/opt/slurm/bin/sbatch";
  opts.wait = true;
  Submission sub = submit(p, opts, std::ref(sbatch));
  ASSERT_EQ(sbatch.calls.size(), 2u) << "no warm job: its cache is there";
  EXPECT_FALSE(sub.warm_job);
  EXPECT_EQ(sub.status.missing, (std::vector<int>{3}));
  EXPECT_EQ(sub.chunks, (std::vector<int>{1}));
  EXPECT_EQ(sbatch.calls[0].front(), "/opt/slurm/bin/sbatch");
  EXPECT_TRUE(has(sbatch.calls[0], "--array=1%2"));
  for (const std::string& a : sbatch.calls[0]) EXPECT_EQ(a.rfind("--dependency", 0), std::string::npos);
  EXPECT_TRUE(has(sbatch.calls[1], "--wait"));
  EXPECT_EQ(sub.verify_exit, 0);

  write_frame(3);
  FakeSbatch none;
  Submission done = submit(p, opts, std::ref(none));
  EXPECT_TRUE(done.nothing_to_do());
  EXPECT_TRUE(none.calls.empty());
}

TEST_F(SubmitTest, ADamagedWarmCacheIsBuiltAgain) {
  FarmPlan p = plan();
  fs::create_directories(fs::path(p.warm_cache_file()).parent_path());
  std::ofstream(p.warm_cache_file()) << "not a cache";
  EXPECT_FALSE(warm_cache_ready(p));
  FakeSbatch sbatch;
  Submission sub = submit(p, {}, std::ref(sbatch));
  EXPECT_TRUE(sub.warm_job.has_value());
}

TEST_F(SubmitTest, SbatchFailuresAreOneLineErrors) {
  FarmPlan p = plan();
  FakeSbatch sbatch;
  sbatch.exit_code = 1;
  sbatch.err = "sbatch: error: invalid partition specified: gpu\nmore\n";
  try {
    submit(p, {}, std::ref(sbatch));
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    std::string what = e.what();
    EXPECT_NE(what.find("invalid partition specified"), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  }
  // sbatch --wait exits with the verify job's code after printing the id: a result, not an error.
  FakeSbatch waits;
  SubmitOptions opts;
  opts.wait = true;
  auto runner = [&](const std::vector<std::string>& argv) {
    CommandResult r = waits(argv);
    if (has(argv, "--wait")) r.exit_code = 1;
    return r;
  };
  Submission sub = submit(p, opts, runner);
  EXPECT_EQ(sub.verify_exit, 1);
}

TEST(RunCommand, CapturesStreamsAndExitCode) {
  CommandResult r = run_command({"sh", "-c", "echo out; echo err >&2; exit 3"});
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_EQ(r.out, "out\n");
  EXPECT_EQ(r.err, "err\n");
  // More than a pipe holds on both streams at once must not deadlock.
  CommandResult big = run_command(
      {"sh", "-c", "i=0; while [ $i -lt 20000 ]; do echo xxxxxxxxxx; echo yyyyyyyyyy >&2; "
                   "i=$((i+1)); done"});
  EXPECT_EQ(big.exit_code, 0);
  EXPECT_EQ(big.out.size(), 20000u * 11u);
  EXPECT_EQ(big.err.size(), 20000u * 11u);
  CommandResult missing = run_command({"/nonexistent/sbatch"});
  EXPECT_EQ(missing.exit_code, 127);
  EXPECT_NE(missing.err.find("/nonexistent/sbatch"), std::string::npos);
}

}  // namespace
