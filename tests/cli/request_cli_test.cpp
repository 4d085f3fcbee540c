// One request for every front end, end to end: what --print-request prints is what --request
// renders (with the command line's options over it), and a request rendered by one front end
// gives the image another gives for the same request: `render` against a one-frame `sequence`, a
// farm chunk against the same frames of a local sequence from the same warm cache.
#include <gtest/gtest.h>

#include "cli_harness.h"

#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "dofcache/image/image_io.h"
#include "dofcache/sequence/sequence_renderer.h"

namespace fs = std::filesystem;

namespace {

using dofcache::testing::slurp;

const std::string kScenes = std::string(DOFCACHE_SOURCE_DIR) + "/scenes/";
const std::string kQuick = " --width 32 --light-samples 1 --gather-rays 4 --threads 2";

// Bit for bit: every channel of every pixel.
void expect_same_image(const std::string& a, const std::string& b) {
  const dofcache::image::Image x = dofcache::image::read_image(a);
  const dofcache::image::Image y = dofcache::image::read_image(b);
  ASSERT_EQ(x.width(), y.width());
  ASSERT_EQ(x.height(), y.height());
  ASSERT_EQ(x.channels(), y.channels());
  EXPECT_TRUE(x.data() == y.data()) << a << " and " << b << " differ";
}

class RequestCli : public dofcache::testing::CliTest {
 protected:
  nlohmann::json print_request(const std::string& args) {
    dofcache::testing::CliResult r = run(args + " --print-request");
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return nlohmann::json::parse(r.out);
  }
};

TEST_F(RequestCli, PrintRequestShowsWhatAutoChoseAndRendersNothing) {
  const nlohmann::json drt = print_request("render --spp 64 -o " + path("x.png") + kQuick);
  EXPECT_FALSE(fs::exists(dir_ / "x.png"));
  EXPECT_EQ(drt.at("kind"), "image");
  EXPECT_EQ(drt.at("cache").at("backend"), "vdb");  // auto: drt integrates the lens
  EXPECT_EQ(drt.at("adaptive").at("mode"), "on");   // auto: on for drt
  // round(spp / 16) with 4 gather rays: that of 64 * 32 / 4 = 512 lens samples, 32.
  EXPECT_EQ(drt.at("cache").at("sample_quality"), 32);
  EXPECT_EQ(drt.at("image").at("height"), 24);  // the Cornell box camera's 4:3
  EXPECT_EQ(drt.at("threads"), 2);
  EXPECT_TRUE(drt.at("lens").at("focus_distance").is_number());  // autofocus, now fixed
  EXPECT_FALSE(drt.at("choices").empty());

  const nlohmann::json preview = print_request("render --mode preview-occlusion --width 32");
  EXPECT_EQ(preview.at("cache").at("backend"), "none");
  EXPECT_EQ(preview.at("adaptive").at("mode"), "off");
  EXPECT_EQ(preview.at("spp"), 1);                            // quick inputs
  EXPECT_EQ(preview.at("shading").at("light_samples"), 1);  // quick shading
  EXPECT_EQ(preview.at("mode"), "preview-occlusion");

  const nlohmann::json seq = print_request("sequence " + kScenes +
                                           "cornell_box_dolly.gltf --persistent --width 32");
  EXPECT_EQ(seq.at("kind"), "sequence");
  EXPECT_EQ(seq.at("cache").at("backend"), "vdb");  // --persistent alone: vdb
  EXPECT_EQ(seq.at("adaptive").at("mode"), "off");
  EXPECT_EQ(seq.at("cache").at("sample_quality"), 4);  // fixed: cache files record it
  EXPECT_TRUE(seq.at("lens").at("focus_distance").is_null());  // per frame, from the path
}

TEST_F(RequestCli, RequestFileRendersWhatTheOptionsRenderAndOptionsOverrideIt) {
  const std::string opts = " --spp 4 --fstop 1.4 --seed 7" + kQuick;
  ASSERT_EQ(run("render -q -o " + path("direct.exr") + opts).exit_code, 0);
  {
    std::ofstream f(dir_ / "req.json");
    f << print_request("render -o " + path("from-file.exr") + opts).dump(2);
  }
  dofcache::testing::CliResult r = run("render -q --request " + path("req.json"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  expect_same_image(path("direct.exr"), path("from-file.exr"));

  // An option on the command line overrides the file's field; the rest stays the file's.
  r = run("render -q --request " + path("req.json") + " --spp 2 -o " + path("two.exr") +
          " --stats-json " + path("two.json"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json stats = nlohmann::json::parse(slurp(dir_ / "two.json"));
  EXPECT_EQ(stats.at("spp"), 2);
  EXPECT_EQ(stats.at("seed"), 7);
  EXPECT_DOUBLE_EQ(stats.at("lens").at("fstop").get<double>(), 1.4);

  // Bad request files: one line, non-zero.
  std::ofstream(dir_ / "bad.json") << R"({"cache": {"min_factr": 2}})";
  expect_one_line_error(run("render --request " + path("bad.json")), "cache.min_factr", 1);
  std::ofstream(dir_ / "range.json") << R"({"image": {"width": -3}})";
  expect_one_line_error(run("render --request " + path("range.json")), "image.width", 1);
  std::ofstream(dir_ / "kind.json") << R"({"kind": "sequence"})";
  expect_one_line_error(run("render --request " + path("kind.json")), "kind sequence", 1);
  expect_one_line_error(run("render --request " + path("missing.json")), "missing.json", 1);
}

// A one-frame sequence renders frame 0 with the seed frame_seed(seed, 0) and the camera of the
// path at frame 0 (the dolly's node sits at its first key): `render` with that seed is the same
// request, and gives the same image, raw (EXR) or denoised (PNG).
TEST_F(RequestCli, RenderEqualsAOneFrameSequenceOfTheSameRequest) {
  const std::string scene = kScenes + "cornell_box_dolly.gltf";
  const std::string seed = std::to_string(dofcache::sequence::frame_seed(5, 0));
  const std::string shared =
      " --spp 4 --cache vdb --cache-sample-quality 1 --min-factor 0.5 --cache-direct-below 0"
      " --cache-direct-cost-ratio 0" +
      kQuick;
  ASSERT_EQ(run("sequence -q " + scene + " --frames 0 --seed 5 -o " + path("seq/####.exr")
                + shared)
                .exit_code,
            0);
  // A frame draws its shading from the frame's seed and its lens pattern from the sequence's.
  const std::string seeds = " --seed " + seed + " --pattern-seed 5";
  dofcache::testing::CliResult r =
      run("render -q " + scene + " --adaptive off" + seeds + " -o " + path("render.exr") +
          shared);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  expect_same_image(path("seq/0000.exr"), path("render.exr"));
  // PNG: both denoised (auto), by the same filter from the same features.
  ASSERT_EQ(run("sequence -q " + scene + " --frames 0 --seed 5 -o " + path("seq/####.png") +
                shared).exit_code, 0);
  r = run("render -q " + scene + " --adaptive off" + seeds + " -o " + path("render.png") +
          shared);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  expect_same_image(path("seq/0000.png"), path("render.png"));
  r = run("render -q " + scene + " --adaptive off" + seeds + " -o " + path("raw.png") +
          " --denoise off" + shared);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(slurp(path("raw.png")), slurp(path("render.png")));
}

// A farm chunk runs its stored request: the same frames as a local sequence started from the same
// warm cache with the same options.
TEST_F(RequestCli, FarmChunkEqualsTheLocalSequenceFromTheSameWarmCache) {
  const std::string scene = kScenes + "cornell_box_dolly.gltf";
  const std::string opts = " --spp 4 --cache-sample-quality 1" + kQuick;
  dofcache::testing::CliResult plan =
      run("farm plan " + scene + " --frames 0-3 --chunk 2 --persistent --work-dir " +
          path("farm") + " -o " + path("farm-f/####.exr") + opts);
  ASSERT_EQ(plan.exit_code, 0) << plan.err;
  const std::string commands = (dir_ / "farm" / "commands.sh").string();
  ASSERT_EQ(std::system(("bash '" + commands + "' > /dev/null 2>&1").c_str()), 0);
  dofcache::testing::CliResult local =
      run("sequence -q " + scene + " --frames 2-3 --persistent --cache-in " +
          path("farm/warm-cache.vdb") + " -o " + path("local/####.exr") + opts);
  ASSERT_EQ(local.exit_code, 0) << local.err;
  for (const char* f : {"0002.exr", "0003.exr"})
    expect_same_image((dir_ / "farm-f" / f).string(), (dir_ / "local" / f).string());
  // The chunk's request is a file of the plan, run with --request and nothing else.
  const nlohmann::json chunk =
      nlohmann::json::parse(slurp(dir_ / "farm" / "jobs" / "chunk-001.json"));
  EXPECT_EQ(chunk.at("sequence").at("frames"), "2-3");
  EXPECT_EQ(chunk.at("sequence").at("cache_in"), path("farm/warm-cache.vdb"));
}

}  // namespace
