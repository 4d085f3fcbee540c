// `dofcache farm` end to end without a cluster: a plan run by its commands.sh on this machine
// gives the frames of plain `dofcache sequence` calls, verify finds lost frames, submit calls a
// stand-in sbatch with the right dependency chain, and bad plans are one-line errors.
#include <gtest/gtest.h>

#include "cli_harness.h"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <string>

namespace fs = std::filesystem;

namespace {

using dofcache::testing::slurp;

const std::string kDolly = std::string(DOFCACHE_SOURCE_DIR) + "/scenes/cornell_box_dolly.gltf";
const std::string kQuick = " --width 24 --spp 2 --light-samples 1 --gather-rays 4 "
                           "--cache-sample-quality 1 ";

class FarmCli : public dofcache::testing::CliTest {
 protected:
  // A plan of frames 0-2 in chunks of 2 with the cache carried through each chunk.
  dofcache::testing::CliResult plan(const std::string& extra = "") {
    return run("farm plan " + kDolly + " --frames 0-2" + kQuick + "--out " + path("f/####.exr") +
               " --cache vdb --persistent --chunk 2 --warm-spp 1 --work-dir " + path("work") +
               " " + extra);
  }
};

TEST_F(FarmCli, PlanRunLocallyEqualsPlainSequenceCallsAndVerifyFindsLostFrames) {
  auto p = plan("--cpus-per-task 2");
  ASSERT_EQ(p.exit_code, 0) << p.err;
  EXPECT_NE(p.out.find("frames 0-2 in 2 chunk(s)"), std::string::npos) << p.out;
  for (const char* f : {"farm.json", "warm.sbatch", "render.sbatch", "verify.sbatch",
                        "commands.sh"})
    EXPECT_TRUE(fs::exists(dir_ / "work" / f)) << f;
  // The warm pass renders 1 lens sample, the frames 2, but both must make cache samples of the
  // same quality (the cache file records it): every job's stored request names it, and each job
  // runs its request alone.
  std::string commands = slurp(dir_ / "work" / "commands.sh");
  std::size_t lines = 0;
  for (std::size_t at = 0; (at = commands.find(" sequence --request ", at)) != std::string::npos; ++at)
    ++lines;
  EXPECT_EQ(lines, 3u) << commands;  // warm + 2 chunks
  for (const char* job : {"warm.json", "chunk-000.json", "chunk-001.json"}) {
    const nlohmann::json j = nlohmann::json::parse(slurp(dir_ / "work" / "jobs" / job));
    EXPECT_EQ(j.at("cache").at("sample_quality"), 1) << job;
    EXPECT_EQ(j.at("threads"), 2) << job;  // --cpus-per-task
  }
  EXPECT_EQ(nlohmann::json::parse(slurp(dir_ / "work" / "jobs" / "warm.json")).at("spp"), 1);

  auto before = run("farm verify " + path("work"));
  expect_one_line_error(before, "3 of 3 frames missing or incomplete: 0-2 (chunks 0-1)", 1);

  // Another farm manager (or one machine) runs commands.sh: warm pass, chunks, verify.
  int status = std::system(("bash " + path("work/commands.sh") + " >" + path("log") + " 2>&1").c_str());
  ASSERT_EQ(status, 0) << slurp(dir_ / "log");
  auto ok = run("farm verify " + path("work") + " --json " + path("verify.json"));
  EXPECT_EQ(ok.exit_code, 0) << ok.err;
  EXPECT_NE(ok.out.find("3 of 3 frames complete"), std::string::npos) << ok.out;
  EXPECT_NE(slurp(dir_ / "verify.json").find("\"missing\": []"), std::string::npos);

  // The second chunk equals a plain sequence call from the same warm cache.
  auto single = run("sequence " + kDolly + " --frames 2" + kQuick + "--out " +
                    path("s/####.exr") + " --cache vdb --persistent --threads 1 --cache-in " +
                    path("work/warm-cache.vdb") + " -q");
  ASSERT_EQ(single.exit_code, 0) << single.err;
  auto cmp = run("compare " + path("f/0002.exr") + " " + path("s/0002.exr") + " --json");
  EXPECT_NE(cmp.out.find("\"mse\": 0.0,"), std::string::npos) << cmp.out;

  fs::remove(dir_ / "f" / "0001.exr");
  auto lost = run("farm verify " + path("work"));
  expect_one_line_error(lost, "1 of 3 frames missing or incomplete: 1 (chunks 0)", 1);
}

TEST_F(FarmCli, TemporalFilterRunsAfterVerifyOverEveryChunksFrames) {
  auto p = plan("--temporal 1");
  ASSERT_EQ(p.exit_code, 0) << p.err;
  // The chunks render only; the verify job then filters the whole path.
  for (const char* job : {"warm.json", "chunk-000.json", "chunk-001.json"})
    EXPECT_EQ(nlohmann::json::parse(slurp(dir_ / "work" / "jobs" / job))
                  .at("sequence").at("temporal"), 0) << job;
  const nlohmann::json t = nlohmann::json::parse(slurp(dir_ / "work" / "jobs" / "temporal.json"));
  EXPECT_EQ(t.at("sequence").at("temporal_only"), true);
  EXPECT_EQ(t.at("sequence").at("frames"), "0-2");
  EXPECT_EQ(t.at("denoise"), "on");  // the chunks write the denoiser's layers
  const std::string verify = slurp(dir_ / "work" / "verify.sbatch");
  EXPECT_LT(verify.find("farm verify"), verify.find("temporal.json")) << verify;
  int status = std::system(("bash " + path("work/commands.sh") + " >" + path("log") + " 2>&1").c_str());
  ASSERT_EQ(status, 0) << slurp(dir_ / "log");
  // Frame 1 of the chunk (0-1) was filtered with frame 2 of the next chunk, as one sequence
  // process filters it.
  auto whole = run("sequence " + kDolly + " --frames 0-2" + kQuick + "--out " +
                   path("f/####.exr") + " --temporal 1 --temporal-only --temporal-output " +
                   path("w/####.exr") + " -q");
  ASSERT_EQ(whole.exit_code, 0) << whole.err;
  for (const char* f : {"0000", "0001", "0002"}) {
    auto cmp = run("compare " + path(std::string("f/") + f + ".temporal.exr") + " " +
                   path(std::string("w/") + f + ".exr") + " --json");
    EXPECT_NE(cmp.out.find("\"mse\": 0.0,"), std::string::npos) << f << cmp.out;
  }
  expect_one_line_error(plan("--temporal 1 --temporal-only"), "drop --temporal-only", 1);
}

TEST_F(FarmCli, SubmitChainsJobsThroughSbatch) {
  ASSERT_EQ(plan("--partition render --time 1:00:00").exit_code, 0);
  // A stand-in sbatch: records its arguments, answers with job ids 41, 42, 43.
  fs::path fake = dir_ / "sbatch";
  std::ofstream(fake) << "#!/bin/bash\n"
                         "n=$(( $(cat '" << path("count") << "' 2>/dev/null || echo 40) + 1 ))\n"
                         "echo $n > '" << path("count") << "'\n"
                         "echo \"$*\" >> '" << path("calls") << "'\n"
                         "echo \"$n;test\"\n";
  fs::permissions(fake, fs::perms::owner_all);
  auto r = run("farm submit " + path("work") + " --sbatch " + fake.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("warm-cache job 41"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("render job array 42, tasks 0-1 (after 41)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("verify job 43 (after 42)"), std::string::npos) << r.out;
  std::string calls = slurp(dir_ / "calls");
  EXPECT_NE(calls.find("--parsable " + path("work/warm.sbatch")), std::string::npos) << calls;
  EXPECT_NE(calls.find("--array=0-1 --dependency=afterok:41 " + path("work/render.sbatch")),
            std::string::npos)
      << calls;
  EXPECT_NE(calls.find("--dependency=afterany:42 " + path("work/verify.sbatch")),
            std::string::npos)
      << calls;
  EXPECT_NE(slurp(dir_ / "work" / "render.sbatch").find("#SBATCH --partition=render\n"),
            std::string::npos);

  auto dry = run("farm submit " + path("work") + " --dry-run");
  EXPECT_EQ(dry.exit_code, 0) << dry.err;
  EXPECT_NE(dry.out.find("would run  sbatch --parsable --array=0-1 --dependency=afterok:1"),
            std::string::npos)
      << dry.out;

  auto broken = run("farm submit " + path("work") + " --sbatch /nonexistent/sbatch");
  expect_one_line_error(broken, "sbatch failed", 1);
}

TEST_F(FarmCli, BadPlansAreOneLineErrors) {
  expect_one_line_error(plan("--cache-in x.vdb"), "--cache-in is set by the plan", 1);
  expect_one_line_error(plan("--spp 0"), "in the sequence options", 1);
  expect_one_line_error(plan("--no-such-option"), "in the sequence options", 1);
  expect_one_line_error(run("farm plan " + path("missing.gltf") + " --work-dir " + path("w")),
                        "missing.gltf", 1);
  expect_one_line_error(run("farm plan " + kDolly + " --frames 0-2"), "--work-dir", 2);
  EXPECT_FALSE(fs::exists(dir_ / "w" / "farm.json"));

  ASSERT_EQ(plan().exit_code, 0);
  EXPECT_EQ(plan().exit_code, 0) << "the same plan again is fine";
  expect_one_line_error(plan("--warm-step 1"), "holds another farm plan", 1);
  EXPECT_EQ(plan("--warm-step 1 --force").exit_code, 0);
  EXPECT_EQ(nlohmann::json::parse(slurp(dir_ / "work" / "jobs" / "warm.json"))
                .at("sequence")
                .at("frame_step"),
            1);

  expect_one_line_error(run("farm verify " + path("nowhere")), "no farm plan here", 1);
  std::ofstream(dir_ / "work" / "farm.json") << "{}";
  expect_one_line_error(run("farm submit " + path("work")), "not a dofcache farm plan", 1);
}

}  // namespace
