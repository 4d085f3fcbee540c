// Farm plans: chunking, the commands each job runs, the generated scripts (run for real with bash
// and a stand-in executable, so quoting is checked by a shell), the plan file, and which frames
// and chunks are missing.
#include <gtest/gtest.h>

#include "scratch_dir.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "dofcache/core/error.h"
#include "dofcache/farm/plan.h"
#include "dofcache/image/image_io.h"

using namespace dofcache;
using namespace dofcache::farm;
namespace fs = std::filesystem;

namespace {

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

bool contains(const std::string& text, const std::string& needle) {
  return text.find(needle) != std::string::npos;
}

std::string frame_name(int frame) {
  char name[32];
  std::snprintf(name, sizeof name, "%04d.exr", frame);
  return name;
}

// Index of `value` in argv, or -1.
class FarmPlanTest : public dofcache::testing::ScratchDirTest {
 protected:
  FarmSettings settings() const {
    FarmSettings s;
    s.dofcache = "/opt/dofcache/bin/dofcache";
    s.work_dir = (dir_ / "work").string();
    s.run_dir = dir_.string();
    s.request.scene = "scene.gltf";
    s.request.width = 64;
    s.request.spp = 16;
    s.request.out = "f/####.exr";
    s.request.cache = "vdb";
    s.request.sequence.persistent = true;
    s.first = 10;
    s.last = 15;
    s.chunk = 4;
    s.output = (dir_ / "f" / "####.exr").string();
    s.width = 64;
    s.height = 48;
    s.cache = "vdb";
    s.carry = true;
    return s;
  }
};

TEST(FarmChunks, CutTheRangeIntoRunsWithAShorterLast) {
  std::vector<Chunk> c = make_chunks(10, 15, 4);
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c[0].index, 0);
  EXPECT_EQ(c[0].first, 10);
  EXPECT_EQ(c[0].last, 13);
  EXPECT_EQ(c[1].index, 1);
  EXPECT_EQ(c[1].first, 14);
  EXPECT_EQ(c[1].last, 15);

  std::vector<Chunk> even = make_chunks(0, 5, 2);
  ASSERT_EQ(even.size(), 3u);
  EXPECT_EQ(even[2].first, 4);
  EXPECT_EQ(even[2].last, 5);

  std::vector<Chunk> one = make_chunks(7, 7, 8);
  ASSERT_EQ(one.size(), 1u);
  EXPECT_EQ(one[0].first, 7);
  EXPECT_EQ(one[0].last, 7);

  EXPECT_THROW(make_chunks(0, 5, 0), Error);
  EXPECT_THROW(make_chunks(5, 4, 1), Error);
}

TEST(FarmText, RangesAndShellQuoting) {
  EXPECT_EQ(format_ranges({0, 1, 2, 3, 7, 9, 10}), "0-3,7,9-10");
  EXPECT_EQ(format_ranges({5}), "5");
  EXPECT_EQ(format_ranges({}), "");

  EXPECT_EQ(shell_quote("frames/####.exr"), "frames/####.exr");
  EXPECT_EQ(shell_quote("--time=2:00:00"), "--time=2:00:00");
  EXPECT_EQ(shell_quote("a b"), "'a b'");
  EXPECT_EQ(shell_quote("it's"), "'it'\\''s'");
  EXPECT_EQ(shell_quote(""), "''");
  EXPECT_EQ(shell_quote("$HOME"), "'$HOME'");
  EXPECT_EQ(shell_quote("#comment"), "'#comment'");
  EXPECT_EQ(shell_join({"a", "b c"}), "a 'b c'");
}

TEST_F(FarmPlanTest, SettingsAreValidated) {
  EXPECT_NO_THROW(FarmPlan{settings()});
  auto expect_bad = [&](auto change, const std::string& needle) {
    FarmSettings s = settings();
    change(s);
    try {
      FarmPlan p(s);
      ADD_FAILURE() << "accepted; expected an error about " << needle;
    } catch (const Error& e) {
      EXPECT_TRUE(contains(e.what(), needle)) << e.what();
    }
  };
  expect_bad([](FarmSettings& s) { s.work_dir = "relative/work"; }, "absolute");
  expect_bad([](FarmSettings& s) { s.output = (fs::path(s.run_dir) / "f.exr").string(); }, "#");
  expect_bad([](FarmSettings& s) { s.chunk = 0; }, "--chunk");
  expect_bad([](FarmSettings& s) { s.last = s.first - 1; }, "frame range");
  expect_bad([](FarmSettings& s) { s.cache = "none"; }, "--persistent needs a cache");
  expect_bad([](FarmSettings& s) { s.request.sequence.cache_in = "x.vdb"; }, "cache_in");
  expect_bad([](FarmSettings& s) { s.request.sequence.frame_step = 2; }, "frame_step");
  expect_bad([](FarmSettings& s) { s.request.stats_json = "s.json"; }, "stats_json");
  expect_bad([](FarmSettings& s) { s.request.kind = request::Kind::Image; }, "sequence");
  expect_bad([](FarmSettings& s) { s.slurm.job_name = "two words"; }, "job name");
  expect_bad([](FarmSettings& s) { s.slurm.extra = {"qos=low"}; }, "sbatch option");
  // A plan of two billion frames would be two billion chunks (and script lines): refused
  // before the chunks are made.
  expect_bad([](FarmSettings& s) { s.first = 0, s.last = 2147483647; }, "more than 1000000 frames");
  FarmSettings most = settings();
  most.first = 0, most.last = kMaxFarmFrames - 1, most.chunk = 1000;
  EXPECT_EQ(FarmPlan(most).chunks().size(), 1000u);
  expect_bad([](FarmSettings& s) { s.first = 0, s.last = kMaxFarmFrames; }, "more than");
}

TEST_F(FarmPlanTest, ChunkRequestsStartFromTheWarmCacheWithTheirOwnCheckpoint) {
  FarmSettings s = settings();
  s.slurm.cpus_per_task = 8;
  FarmPlan plan(s);
  ASSERT_EQ(plan.chunks().size(), 2u);
  const request::RenderRequest a = plan.chunk_request(plan.chunks()[0]);
  const request::RenderRequest b = plan.chunk_request(plan.chunks()[1]);
  // Each job runs its stored request, nothing else.
  EXPECT_EQ(plan.chunk_command(plan.chunks()[0]),
            (std::vector<std::string>{s.dofcache, "sequence", "--request",
                                      plan.chunk_request_file(plan.chunks()[0])}));
  // The plan's request, with what the plan sets per job.
  EXPECT_EQ(a.scene, "scene.gltf");
  EXPECT_EQ(a.width, 64);
  EXPECT_EQ(a.out, "f/####.exr");
  EXPECT_TRUE(a.sequence.persistent);
  EXPECT_EQ(a.sequence.frames, "10-13");
  EXPECT_EQ(b.sequence.frames, "14-15");
  EXPECT_EQ(a.sequence.cache_in, plan.warm_cache_file());
  // The warm pass rendered the same path: a lens it animates is no mismatch.
  EXPECT_TRUE(a.sequence.cache_any_lens);
  EXPECT_EQ(a.threads, 8);
  EXPECT_FALSE(a.sequence.checkpoint.empty());
  EXPECT_NE(a.sequence.checkpoint, b.sequence.checkpoint);
  EXPECT_NE(a.stats_json, b.stats_json);

  // threads named in the request win; no warm pass, no cache_in.
  s.request.threads = 3;
  s.warm = false;
  FarmPlan cold(s);
  const request::RenderRequest c = cold.chunk_request(cold.chunks()[0]);
  EXPECT_EQ(c.threads, 3);
  EXPECT_TRUE(c.sequence.cache_in.empty());
  EXPECT_FALSE(c.sequence.cache_any_lens);
  EXPECT_FALSE(cold.has_warm_pass());
}

TEST_F(FarmPlanTest, WarmRequestRendersKeyframesAtFewSamplesIntoTheWarmCache) {
  FarmSettings s = settings();
  s.carry = false;  // fresh cache per frame: the warm pass must still carry its own cache
  s.request.sequence.persistent = false;
  s.warm_spp = 2;
  FarmPlan plan(s);
  const request::RenderRequest w = plan.warm_request();
  EXPECT_EQ(w.sequence.frames, "10-15");
  EXPECT_EQ(w.sequence.frame_step, 4);  // one keyframe per chunk by default
  EXPECT_EQ(w.sequence.cache_out, plan.warm_cache_file());
  EXPECT_EQ(w.spp, 2);
  EXPECT_TRUE(w.sequence.persistent);
  EXPECT_TRUE(contains(w.out, s.work_dir));  // its keyframes go to the work directory

  s.warm_step = 3;
  s.warm_spp = 0;  // the frames' own sample count
  FarmPlan plan3(s);
  const request::RenderRequest w3 = plan3.warm_request();
  EXPECT_EQ(w3.sequence.frame_step, 3);
  EXPECT_EQ(w3.spp, 16);
}

TEST_F(FarmPlanTest, ScriptsCarryTheClusterOptionsGiven) {
  FarmSettings s = settings();
  FarmPlan bare(s);
  std::string r = bare.render_script();
  EXPECT_TRUE(contains(r, "#SBATCH --array=0-1\n")) << r;
  EXPECT_TRUE(contains(r, "#SBATCH --chdir=" + s.run_dir + "\n"));
  EXPECT_TRUE(contains(r, "#SBATCH --kill-on-invalid-dep=yes\n"));
  EXPECT_FALSE(contains(r, "--partition")) << "nothing about the cluster is assumed";
  EXPECT_FALSE(contains(r, "--time"));
  EXPECT_FALSE(contains(r, "--cpus-per-task"));
  EXPECT_FALSE(contains(bare.warm_script(), "--array"));

  s.slurm.partition = "render";
  s.slurm.time_limit = "2:00:00";
  s.slurm.cpus_per_task = 16;
  s.slurm.memory = "8G";
  s.slurm.account = "lab";
  s.slurm.max_running = 4;
  s.slurm.extra = {"--qos=low"};
  FarmPlan full(s);
  for (const std::string& script :
       {full.warm_script(), full.render_script(), full.verify_script()}) {
    EXPECT_TRUE(contains(script, "#SBATCH --partition=render\n")) << script;
    EXPECT_TRUE(contains(script, "#SBATCH --time=2:00:00\n"));
    EXPECT_TRUE(contains(script, "#SBATCH --cpus-per-task=16\n"));
    EXPECT_TRUE(contains(script, "#SBATCH --mem=8G\n"));
    EXPECT_TRUE(contains(script, "#SBATCH --account=lab\n"));
    EXPECT_TRUE(contains(script, "#SBATCH --qos=low\n"));
  }
  EXPECT_TRUE(contains(full.render_script(), "#SBATCH --array=0-1%4\n"));
  EXPECT_TRUE(contains(full.verify_script(), "farm verify"));
}

// The scripts are run by bash with a stand-in for dofcache that records its arguments: each array
// task must run exactly its chunk's command, however odd the paths.
TEST_F(FarmPlanTest, ScriptsRunExactlyThePlannedCommands) {
  fs::path fake = dir_ / "bin dir" / "fake dofcache";
  fs::create_directories(fake.parent_path());
  {
    std::ofstream f(fake);
    f << "#!/bin/bash\nfor a in \"$@\"; do printf '%s\\n' \"$a\"; done > \"$ARGS_OUT\"\n";
  }
  fs::permissions(fake, fs::perms::owner_all);
  FarmSettings s = settings();
  s.dofcache = fake.string();
  s.request.scene = "my scene's.gltf";
  s.request.camera = "$cam #1";
  FarmPlan plan(s);
  plan.write();

  auto run = [&](const std::string& script, const std::string& task) {
    fs::path out = dir_ / ("args-" + task);
    std::string cmd = "cd '" + dir_.string() + "' && ARGS_OUT='" + out.string() +
                      "' SLURM_ARRAY_TASK_ID=" + task + " bash '" + script + "' 2>/dev/null";
    int status = std::system(cmd.c_str());
    std::vector<std::string> args;
    std::istringstream in(slurp(out));
    for (std::string line; std::getline(in, line);) args.push_back(line);
    return std::make_pair(status, args);
  };
  for (const Chunk& c : plan.chunks()) {
    auto [status, args] = run(plan.script_file("render"), std::to_string(c.index));
    EXPECT_EQ(status, 0);
    std::vector<std::string> expected = plan.chunk_command(c);
    expected.erase(expected.begin());  // argv[0]
    EXPECT_EQ(args, expected) << "array task " << c.index;
  }
  auto [bad_status, bad_args] = run(plan.script_file("render"), "7");
  EXPECT_NE(bad_status, 0) << "a task index outside the plan must fail";

  auto [warm_status, warm_args] = run(plan.script_file("warm"), "");
  EXPECT_EQ(warm_status, 0);
  std::vector<std::string> warm = plan.warm_command();
  warm.erase(warm.begin());
  EXPECT_EQ(warm_args, warm);

  // commands.sh: the same commands in order (the stand-in overwrites its record each time, so
  // the last one, verify, is what remains).
  auto [all_status, last_args] = run(plan.commands_file(), "");
  EXPECT_EQ(all_status, 0);
  std::vector<std::string> verify = plan.verify_command();
  verify.erase(verify.begin());
  EXPECT_EQ(last_args, verify);
  std::string commands = slurp(plan.commands_file());
  EXPECT_TRUE(contains(commands, shell_join(plan.warm_command()) + "\n"));
  for (const Chunk& c : plan.chunks())
    EXPECT_TRUE(contains(commands, shell_join(plan.chunk_command(c)) + "\n"));
}

TEST_F(FarmPlanTest, PlanFileRoundTripsAndBadFilesAreRefused) {
  FarmSettings s = settings();
  s.slurm.partition = "render";
  s.slurm.extra = {"--qos=low", "--exclusive"};
  FarmPlan plan(s);
  plan.write();
  FarmPlan back = FarmPlan::load(s.work_dir);
  EXPECT_EQ(back.to_json(), plan.to_json());
  EXPECT_EQ(request::to_json(back.settings().request), request::to_json(s.request));
  // The jobs' requests are stored beside the plan, read back as written.
  const Chunk& c0 = plan.chunks()[0];
  EXPECT_EQ(request::to_json(request::load_request(plan.chunk_request_file(c0))),
            request::to_json(plan.chunk_request(c0)));
  EXPECT_EQ(request::to_json(request::load_request(plan.request_file("warm"))),
            request::to_json(plan.warm_request()));
  EXPECT_EQ(back.chunks().size(), plan.chunks().size());

  auto expect_load_error = [&](const std::string& text, const std::string& needle) {
    fs::path d = dir_ / "bad";
    fs::create_directories(d);
    if (!text.empty()) std::ofstream(d / "farm.json") << text;
    try {
      FarmPlan::load(d.string());
      ADD_FAILURE() << "loaded a bad plan";
    } catch (const Error& e) {
      std::string what = e.what();
      EXPECT_TRUE(contains(what, needle)) << what;
      EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    }
    fs::remove_all(d);
  };
  expect_load_error("", "no farm plan here");
  expect_load_error("{ not json", "not valid JSON");
  expect_load_error(R"({"dofcache_farm_plan": 99})", "not a dofcache farm plan");
  nlohmann::json j = plan.to_json();
  j.erase("chunk");
  expect_load_error(j.dump(), "not a valid dofcache farm plan");
  j = plan.to_json();
  j["chunk"] = 0;
  expect_load_error(j.dump(), "--chunk");
}

TEST_F(FarmPlanTest, MissingFramesAndTheChunksThatHoldThem) {
  FarmSettings s = settings();  // frames 10-15, chunks 10-13 and 14-15, 64x48
  FarmPlan plan(s);
  fs::create_directories(dir_ / "f");
  image::Image good(64, 48, 3), wrong(32, 24, 3);
  for (int f : {10, 11, 13, 14, 15}) image::write_image((dir_ / "f" / frame_name(f)).string(), good);
  image::write_image((dir_ / "f" / frame_name(14)).string(), wrong);  // wrong size: not complete
  std::ofstream(dir_ / "f" / frame_name(15)) << "truncated";           // unreadable: not complete
  FrameStatus st = check_frames(plan);
  EXPECT_EQ(st.complete, (std::vector<int>{10, 11, 13}));
  EXPECT_EQ(st.missing, (std::vector<int>{12, 14, 15}));
  EXPECT_EQ(chunks_to_render(plan, st), (std::vector<int>{0, 1}));

  image::write_image((dir_ / "f" / frame_name(12)).string(), good);
  st = check_frames(plan);
  EXPECT_EQ(chunks_to_render(plan, st), (std::vector<int>{1}));
}

}  // namespace
