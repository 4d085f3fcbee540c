// The `dofcache` executable end to end: good runs produce files, bad input gives one line on
// stderr, a non-zero exit and no output file.
#include <gtest/gtest.h>

#include "cli_harness.h"
#include "dofcache/core/error.h"
#include "dofcache/image/image_io.h"

#include <nlohmann/json.hpp>

#include <sys/wait.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

using dofcache::testing::slurp;
namespace testing = dofcache::testing;

class Cli : public testing::CliTest {
 protected:
  // A bad run: non-zero exit, exactly one line on stderr starting with "dofcache: error:", and no
  // file left in the output directory other than the captured streams.
  void expect_clean_failure(const std::string& args, const std::string& needle) {
    expect_one_line_error(run(args), needle);
    for (const auto& e : fs::directory_iterator(dir_)) {
      std::string name = e.path().filename().string();
      bool allowed = name == "stdout" || name == "stderr" || e.path().extension() == ".gltf" ||
                     e.path().extension() == ".bin";
      EXPECT_TRUE(allowed) << "left behind: " << name;
    }
  }

  fs::path write(const std::string& name, const std::string& text) {
    std::ofstream(dir_ / name) << text;
    return dir_ / name;
  }
};

std::string base64(const std::vector<unsigned char>& bytes) {
  static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (size_t i = 0; i < bytes.size(); i += 3) {
    unsigned v = bytes[i] << 16 | (i + 1 < bytes.size() ? bytes[i + 1] << 8 : 0) |
                 (i + 2 < bytes.size() ? bytes[i + 2] : 0);
    out += t[(v >> 18) & 63];
    out += t[(v >> 12) & 63];
    out += i + 1 < bytes.size() ? t[(v >> 6) & 63] : '=';
    out += i + 2 < bytes.size() ? t[v & 63] : '=';
  }
  return out;
}

// One triangle with the given vertex positions; `count` overrides the accessor count.
std::string triangle_gltf(const std::array<float, 9>& p, int count = 3,
                          const std::string& buffer_uri = "") {
  std::vector<unsigned char> bytes(sizeof(float) * 9);
  std::memcpy(bytes.data(), p.data(), bytes.size());
  std::string uri = buffer_uri.empty()
                        ? "data:application/octet-stream;base64," + base64(bytes)
                        : buffer_uri;
  return R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],
    "nodes":[{"mesh":0}],
    "meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],
    "accessors":[{"bufferView":0,"componentType":5126,"count":)" +
         std::to_string(count) + R"(,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}],
    "bufferViews":[{"buffer":0,"byteLength":36}],
    "buffers":[{"byteLength":36,"uri":")" + uri + R"("}]})";
}

const std::array<float, 9> kGood = {0, 0, 0, 1, 0, 0, 0, 1, 0};
const std::string kTiny = " --width 24 --height 18 --spp 1 --gather-rays 2 --light-samples 1 -q";

TEST_F(Cli, DefaultSceneRendersToPngAndExr) {
  testing::CliResult r = run("render --out " + (dir_ / "a.png").string() + kTiny);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(fs::exists(dir_ / "a.png"));
  EXPECT_NE(r.out.find("a.png"), std::string::npos);  // says where the image went
  r = run("render --out " + (dir_ / "a.exr").string() + kTiny + " --stats-json " +
          (dir_ / "s.json").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(fs::exists(dir_ / "a.exr"));
  EXPECT_NE(slurp(dir_ / "s.json").find("rays_per_second"), std::string::npos);
}

// --denoise on with an integrator: a PNG gets the denoised colour; an EXR keeps the raw beauty
// (bit-identical to --denoise off) with the denoised colour and the guides as layers. auto: on
// for a PNG, off for an EXR.
TEST_F(Cli, DenoisedRenderKeepsTheRawBeautyInExr) {
  const std::string opts = " --width 32 --height 24 --spp 4 --gather-rays 2 --light-samples 1 -q";
  auto render = [&](const std::string& out, const std::string& extra) {
    testing::CliResult r = run("render --out " + (dir_ / out).string() + opts + extra);
    EXPECT_EQ(r.exit_code, 0) << r.err;
  };
  render("raw.exr", " --denoise off");
  render("auto.exr", "");
  render("on.exr", " --denoise on --stats-json " + (dir_ / "on.json").string());
  render("on.png", " --denoise on");
  render("auto.png", "");
  render("raw.png", " --denoise off");
  using dofcache::image::read_channels;
  const auto raw = dofcache::image::read_image((dir_ / "raw.exr").string());
  EXPECT_EQ(dofcache::image::read_image((dir_ / "auto.exr").string()).data(), raw.data());
  EXPECT_EQ(dofcache::image::read_image((dir_ / "on.exr").string()).data(), raw.data());
  const auto denoised =
      read_channels((dir_ / "on.exr").string(), {"denoised.R", "denoised.G", "denoised.B"});
  EXPECT_NE(denoised.data(), raw.data());
  for (const char* layer : {"albedo.G", "lens.N.Z", "lens.Z", "lens.coverage", "emission.R",
                            "variance.Y", "Z", "id"})
    EXPECT_NO_THROW(read_channels((dir_ / "on.exr").string(), {layer})) << layer;
  EXPECT_THROW(read_channels((dir_ / "raw.exr").string(), {"denoised.R"}), dofcache::Error);
  EXPECT_NE(slurp(dir_ / "on.json").find("\"denoise\""), std::string::npos);
  EXPECT_NE(slurp(dir_ / "on.png"), slurp(dir_ / "raw.png"));
  EXPECT_EQ(slurp(dir_ / "auto.png"), slurp(dir_ / "on.png"));  // auto: a PNG is denoised
}

// render picks the cache sample quality from --spp unless told: round(spp / 16), at least 1.
TEST_F(Cli, CacheSampleQualityFollowsSppUnlessGiven) {
  auto quality = [&](const std::string& extra) {
    testing::CliResult r = run("render --out " + (dir_ / "c.png").string() +
                               " --width 8 --height 6 --light-samples 1 -q "
                               "--cache vdb --stats-json " + (dir_ / "q.json").string() + extra);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    std::string j = slurp(dir_ / "q.json");
    std::size_t at = j.find("\"sample_quality\": ");
    return at == std::string::npos ? -1 : std::atoi(j.c_str() + at + 18);
  };
  EXPECT_EQ(quality(" --spp 16"), 1);
  EXPECT_EQ(quality(" --spp 96"), 6);
  // A quarter of the default gather rays: four times the quality (a sample's gather rays stay).
  EXPECT_EQ(quality(" --spp 96 --gather-rays 8"), 24);
  EXPECT_EQ(quality(" --spp 96 --cache-sample-quality 5"), 5);
}

// drt renders sample adaptively by default from 4 spp on; --adaptive off and other modes do not,
// and asking for it in accumulation mode is refused in one line.
TEST_F(Cli, AdaptiveSamplingIsTheDrtDefault) {
  auto adaptive = [&](const std::string& extra) {
    testing::CliResult r = run("render --out " + (dir_ / "d.png").string() +
                               " --width 8 --height 6 --gather-rays 1 --light-samples 1 -q "
                               "--stats-json " + (dir_ / "d.json").string() + extra);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return slurp(dir_ / "d.json").find("\"adaptive\": true") != std::string::npos;
  };
  EXPECT_TRUE(adaptive(" --spp 16"));
  EXPECT_TRUE(adaptive(" --spp 4"));   // a pilot of 2
  EXPECT_FALSE(adaptive(" --spp 3"));  // too few samples for a pilot: uniform
  EXPECT_FALSE(adaptive(" --spp 16 --adaptive off"));
  EXPECT_FALSE(adaptive(" --spp 16 --mode accumulation"));
  fs::remove(dir_ / "d.png");
  fs::remove(dir_ / "d.json");
  expect_clean_failure("render --mode accumulation --adaptive on --out " +
                           (dir_ / "o.png").string() + kTiny, "adaptive");
}

// At few lens samples `render` shades in-focus hits per ray rather than caching them
// (kSingleImageDirectBelow); --cache-direct-below 0 caches every hit, as the paper does.
TEST_F(Cli, FewSamplesShadeInFocusHitsPerRay) {
  auto stats = [&](const std::string& extra) {
    testing::CliResult r = run("render --out " + (dir_ / "d.png").string() +
                               " --width 8 --height 6 --spp 4 -q --stats-json " +
                               (dir_ / "d.json").string() + extra);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return slurp(dir_ / "d.json");
  };
  const std::string by_default = stats("");
  EXPECT_NE(by_default.find("\"direct_below\": 50.0"), std::string::npos) << by_default;
  EXPECT_NE(by_default.find("\"direct_cost_ratio\": 2.0"), std::string::npos) << by_default;
  EXPECT_EQ(by_default.find("\"direct\": 0,"), std::string::npos) << by_default;
  const std::string off = stats(" --cache-direct-below 0");
  EXPECT_NE(off.find("\"direct\": 0,"), std::string::npos) << off;
  EXPECT_EQ(off.find("\"lookups\": 0,"), std::string::npos) << off;
  fs::remove(dir_ / "d.png");
  fs::remove(dir_ / "d.json");
  expect_clean_failure("render --cache-direct-below -1 --out " + (dir_ / "o.png").string() + kTiny,
                       "direct");
}

TEST_F(Cli, CompareIdenticalImagesIsExact) {
  ASSERT_EQ(run("render --out " + (dir_ / "a.exr").string() + kTiny).exit_code, 0);
  testing::CliResult r = run("compare --json " + (dir_ / "a.exr").string() + " " + (dir_ / "a.exr").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("\"rel_mse\": 0.0"), std::string::npos) << r.out;
}

TEST_F(Cli, HelpExplainsOptions) {
  testing::CliResult r = run("render --help");
  EXPECT_EQ(r.exit_code, 0);
  for (const char* opt : {"--fstop", "--focus-distance", "--focal-length", "--spp", "--mode",
                          "--seed", "--threads", "--stats-json"})
    EXPECT_NE(r.out.find(opt), std::string::npos) << opt;
}

// The lens options are defined once (common_options.h) for every command that takes them; refocus
// says what an unset one keeps.
TEST_F(Cli, LensOptionsReadTheSameInEveryCommand) {
  const std::string fstop_help = "f-number n (aperture diameter = focal length / n)";
  for (const char* command : {"render", "sequence", "refocus"}) {
    testing::CliResult r = run(std::string(command) + " --help");
    EXPECT_EQ(r.exit_code, 0) << command;
    EXPECT_NE(r.out.find(fstop_help), std::string::npos) << command << ":\n" << r.out;
    EXPECT_NE(r.out.find("Focal length in metres"), std::string::npos) << command;
    EXPECT_NE(r.out.find("Distance in focus, metres"), std::string::npos) << command;
  }
  testing::CliResult r = run("refocus --help");
  EXPECT_NE(r.out.find("(default: the saved lens's)"), std::string::npos) << r.out;
}

// The aperture's shape: described before the render, in the request it prints, and the preview
// says in one line that its shaped scatter draws it.
TEST_F(Cli, ApertureShapeIsDescribedAndThePreviewSaysHowItDrawsIt) {
  const std::string out = (dir_ / "o.png").string();
  const std::string small = " --width 24 --height 18 --spp 1 --gather-rays 2 --light-samples 1";
  testing::CliResult drt = run("render --aperture-blades 6 --anamorphic-ratio 1.5 --out " + out +
                               small);
  ASSERT_EQ(drt.exit_code, 0) << drt.err;
  EXPECT_NE(drt.out.find("aperture 6 blades, a corner at 0 deg, roundness 0, anamorphic ratio "
                         "1.5"), std::string::npos) << drt.out;
  EXPECT_EQ(drt.out.find("shaped scatter"), std::string::npos) << drt.out;
  testing::CliResult pre = run("render --mode preview --aperture-blades 6 --out " + out + small);
  ASSERT_EQ(pre.exit_code, 0) << pre.err;
  EXPECT_NE(pre.out.find("the preview draws this lens's bokeh with its shaped scatter"),
            std::string::npos) << pre.out;
  testing::CliResult req = run("render --aperture-blades 7 --aperture-rotation 15 --print-request");
  ASSERT_EQ(req.exit_code, 0) << req.err;
  EXPECT_NE(req.out.find("\"aperture_blades\": 7"), std::string::npos) << req.out;
  // A vignetting stop: described in millimetres, and kept by the request it prints.
  testing::CliResult stop = run("render --vignetting-stop 0.01,0.02 --out " + out + small);
  ASSERT_EQ(stop.exit_code, 0) << stop.err;
  EXPECT_NE(stop.out.find("vignetting stop 20 mm across at 20 mm"), std::string::npos) << stop.out;
  testing::CliResult stop_req = run("render --vignetting-stop 0.01,0.02 --print-request");
  ASSERT_EQ(stop_req.exit_code, 0) << stop_req.err;
  const nlohmann::json printed =
      nlohmann::json::parse(stop_req.out.substr(stop_req.out.find('{')));
  EXPECT_EQ(printed["lens"]["vignetting_stop"], nlohmann::json({0.01, 0.02})) << stop_req.out;
  testing::CliResult ca = run("render --axial-ca 0.02 --lateral-ca 0.01 --out " + out + small);
  ASSERT_EQ(ca.exit_code, 0) << ca.err;
  EXPECT_NE(ca.out.find("chromatic aberration 20 mm axial, 1 % lateral"), std::string::npos)
      << ca.out;
  testing::CliResult rim = run("render --aperture-profile rim --aperture-profile-strength 0.5 "
                               "--print-request");
  ASSERT_EQ(rim.exit_code, 0) << rim.err;
  const nlohmann::json rim_req = nlohmann::json::parse(rim.out.substr(rim.out.find('{')));
  EXPECT_EQ(rim_req["lens"]["aperture_profile"], "rim") << rim.out;
  EXPECT_EQ(rim_req["lens"]["aperture_profile_strength"], 0.5) << rim.out;
  testing::CliResult tilt = run("render --lens-tilt 2,-1 --lens-shift 0.1,0 --out " + out + small);
  ASSERT_EQ(tilt.exit_code, 0) << tilt.err;
  EXPECT_NE(tilt.out.find("tilt 2, -1 deg, shift 0.1, 0"), std::string::npos) << tilt.out;
  EXPECT_NE(req.out.find("\"aperture_rotation\": 15"), std::string::npos) << req.out;
}

// A real lens from a prescription: described, recorded in the statistics and the EXR's header,
// and every bad choice a one-line error.
TEST_F(Cli, RealLensFromAPrescriptionFile) {
  const std::string lenses = std::string(DOFCACHE_SOURCE_DIR) + "/scenes/lenses/";
  const std::string gauss = " --lens-file " + lenses + "double_gauss_50mm.lens";
  const std::string out = (dir_ / "o.exr").string(), stats = (dir_ / "s.json").string();
  const std::string small = " --width 24 --height 16 --spp 1 --gather-rays 2 --light-samples 1";
  testing::CliResult r = run("render" + gauss + " --fstop 4 --focus-distance 2 --out " + out +
                             " --stats-json " + stats + small);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("double_gauss_50mm.lens (50.4 mm f/4), focus 2 m from the sensor"),
            std::string::npos) << r.out;
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(stats));
  const nlohmann::json& real = j["real_lens"];
  EXPECT_NEAR(real["effective_focal_length"].get<double>(), 0.0504, 0.0002) << real;
  EXPECT_NEAR(real["fstop"].get<double>(), 4.0, 0.001) << real;
  // 24 x 16 pixels fill the 36 x 24 mm sensor; a 50 mm lens focused at 2 m sees about 38 x 26
  // degrees.
  EXPECT_NEAR(real["field_of_view"][0].get<double>(), 38.4, 0.5) << real;
  EXPECT_NEAR(real["field_of_view"][1].get<double>(), 26.2, 0.5) << real;
  const auto parts = dofcache::image::read_multipart_exr(out);
  ASSERT_FALSE(parts.empty());
  EXPECT_EQ(parts[0].attributes.count("real_lens.effective_focal_length"), 1u);
  // Its stop takes blades (their bokeh: tests/render/real_lens_render_test.cpp); the statistics'
  // lens, the thick-lens equivalent the cache and the preview use, has them too.
  testing::CliResult bladed = run("render" + gauss + " --fstop 4 --aperture-blades 6 "
                                  "--aperture-rotation 15 --out " + out + " --stats-json " +
                                  stats + small);
  ASSERT_EQ(bladed.exit_code, 0) << bladed.err;
  const nlohmann::json jb = nlohmann::json::parse(std::ifstream(stats));
  EXPECT_EQ(jb["lens"]["aperture_blades"], 6) << jb["lens"];
  EXPECT_EQ(jb["lens"]["aperture_rotation"], 15.0) << jb["lens"];
  EXPECT_NEAR(jb["lens"]["focal_length"].get<double>(), 0.0504, 0.0002) << jb["lens"];
  // The request it prints keeps the file and the sensor.
  testing::CliResult req = run("render" + gauss + " --sensor-size 0.024,0.016 --sensor-fit "
                               "vertical --print-request");
  ASSERT_EQ(req.exit_code, 0) << req.err;
  const nlohmann::json printed = nlohmann::json::parse(req.out.substr(req.out.find('{')));
  EXPECT_EQ(printed["lens"]["sensor_size"], nlohmann::json({0.024, 0.016})) << req.out;
  EXPECT_EQ(printed["lens"]["sensor_fit"], "vertical") << req.out;
  EXPECT_NE(printed["lens"]["lens_file"].get<std::string>().find("double_gauss_50mm.lens"),
            std::string::npos);
  // The preview draws its thick-lens equivalent, and says so; a fisheye it refuses.
  testing::CliResult pre = run("render --mode preview" + gauss + " --out " + out + small);
  ASSERT_EQ(pre.exit_code, 0) << pre.err;
  EXPECT_NE(pre.out.find("the preview draws the real lens as its thick-lens equivalent"),
            std::string::npos) << pre.out;
  expect_one_line_error(run("render --mode preview --lens-file " + lenses + "fisheye_10mm.lens" +
                            " --out " + out + small),
                        "a fisheye");
  expect_one_line_error(run("render" + gauss + " --fstop 1.4 --out " + out + small),
                        "wider than the lens's widest, f/2.0");
  expect_one_line_error(run("render" + gauss + " --focus-distance 0.1 --out " + out + small),
                        "cannot focus at 0.1");
  expect_one_line_error(run("render" + gauss + " --lens-tilt 2,0 --out " + out + small),
                        "tilt and shift come from its prescription");
  expect_one_line_error(run("render" + gauss + " --vignetting-stop 0.01,0.02 --out " + out + small),
                        "vignetting, chromatic aberration");
  expect_one_line_error(run("render --lens-file " + (dir_ / "none.lens").string() + " --out " +
                            out + small),
                        "cannot read the lens file");
  expect_one_line_error(run("render" + gauss + " --sensor-size 0,0.024 --out " + out + small),
                        "sensor's width and height");
  EXPECT_FALSE(std::filesystem::exists(out + ".tmp"));
}

// A scene with no light of any kind is lit by the default sky, with one notice naming the options;
// a scene with lights, or an explicit environment, gets no notice; --no-default-sky keeps it dark.
TEST_F(Cli, DefaultSkyNoticeExactlyWhenTheSceneHasNoLight) {
  const std::string dark = write("dark.gltf", triangle_gltf(kGood)).string();
  const std::string out = " --out " + (dir_ / "o.exr").string() + kTiny;
  const std::string notice = "dofcache: notice: the scene has no light";
  testing::CliResult r = run("render " + dark + out + " --stats-json " +
                             (dir_ / "s.json").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err.rfind(notice, 0), 0u) << r.err;
  EXPECT_EQ(testing::count_lines(r.err), 1) << r.err;
  for (const char* option : {"--env FILE", "--env-color", "--no-default-sky"})
    EXPECT_NE(r.err.find(option), std::string::npos) << option;
  EXPECT_NE(slurp(dir_ / "s.json").find("\"kind\": \"default_sky\""), std::string::npos);

  for (const std::string& quiet : {dark + " --no-default-sky", dark + " --env-color 0.5,0.5,0.5",
                                   dark + " --env-color 0,0,0", std::string()}) {
    r = run("render " + quiet + out);
    EXPECT_EQ(r.exit_code, 0) << quiet << ": " << r.err;
    EXPECT_EQ(r.err, "") << quiet;
  }
  // The same for sequences, through the shared options.
  r = run("sequence " + dark + " --path " + DOFCACHE_SOURCE_DIR +
          "/scenes/paths/cornell_focus_pull.json --frames 0-0 --width 16 --height 12 --spp 1 -q "
          "--out " + (dir_ / "f####.exr").string());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find(notice), std::string::npos) << r.err;
}

TEST_F(Cli, EnvironmentOptions) {
  testing::CliResult r = run("render --help");
  for (const char* opt : {"--env ", "--env-color", "--env-strength", "--env-rotation",
                          "--env-visible", "--no-default-sky"})
    EXPECT_NE(r.out.find(opt), std::string::npos) << opt;
  const std::string out = " --out " + (dir_ / "o.exr").string() + kTiny;
  expect_clean_failure("render --env " + (dir_ / "nope.hdr").string() + out, "nope.hdr");
  expect_clean_failure("render --env " + std::string(DOFCACHE_SOURCE_DIR) +
                           "/scenes/env/afternoon_sky.hdr --env-color 1,1,1" + out,
                       "exclusive");
  std::ofstream(dir_ / "square.hdr") << "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 2\n"
                                     << std::string(16, '\x80');
  expect_one_line_error(run("render --env " + (dir_ / "square.hdr").string() + out), "2:1");
  r = run("render --env " + std::string(DOFCACHE_SOURCE_DIR) +
          "/scenes/env/afternoon_sky.hdr --env-rotation 90 --env-strength 0.5" + out);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "");
}

// A file that requires an extension the loader does not implement is refused, in one line naming
// the extension (rendering it without the extension would be wrong: glTF 2.0, section 3.12).
TEST_F(Cli, UnsupportedRequiredExtensionIsNamed) {
  std::string gltf = triangle_gltf(kGood);
  gltf.insert(1, R"("extensionsUsed":["EXT_meshopt_compression"],)"
                 R"("extensionsRequired":["EXT_meshopt_compression"],)");
  const fs::path file = write("meshopt.gltf", gltf);
  expect_clean_failure("render " + file.string() + " --out " + (dir_ / "o.png").string() + kTiny,
                       "unsupported extension EXT_meshopt_compression");
}

TEST_F(Cli, MissingFile) {
  expect_clean_failure("render " + (dir_ / "nope.gltf").string() + " --out " +
                           (dir_ / "o.png").string(), "nope.gltf");
}

TEST_F(Cli, InvalidJson) {
  fs::path p = write("bad.gltf", "{ \"asset\": { \"version\": \"2.0\" ");
  expect_clean_failure("render " + p.string() + " --out " + (dir_ / "o.png").string(), "bad.gltf");
}

TEST_F(Cli, MissingBuffer) {
  fs::path p = write("mb.gltf", triangle_gltf(kGood, 3, "missing.bin"));
  expect_clean_failure("render " + p.string() + " --out " + (dir_ / "o.png").string(), "mb.gltf");
}

TEST_F(Cli, OutOfRangeAccessor) {
  fs::path p = write("oor.gltf", triangle_gltf(kGood, 300));
  expect_clean_failure("render " + p.string() + " --out " + (dir_ / "o.png").string(), "oor.gltf");
}

TEST_F(Cli, NanPositions) {
  std::array<float, 9> pos = kGood;
  pos[4] = std::nanf("");
  fs::path p = write("nan.gltf", triangle_gltf(pos));
  expect_clean_failure("render " + p.string() + " --out " + (dir_ / "o.png").string(), "nan.gltf");
}

TEST_F(Cli, ZeroAreaTriangle) {
  fs::path p = write("flat.gltf", triangle_gltf({0, 0, 0, 1, 0, 0, 2, 0, 0}));
  expect_clean_failure("render " + p.string() + " --out " + (dir_ / "o.png").string(), "flat.gltf");
}

TEST_F(Cli, UnknownCamera) {
  expect_clean_failure("render --camera nosuchcam --out " + (dir_ / "o.png").string() + kTiny,
                       "nosuchcam");
}

TEST_F(Cli, AbsurdParameters) {
  expect_clean_failure("render --spp 0 --out " + (dir_ / "o.png").string(), "spp");
  expect_clean_failure("render --fstop -2 --out " + (dir_ / "o.png").string() + kTiny, "f-number");
  expect_clean_failure("render --focus-distance 0.01 --focal-length 0.05 --out " +
                           (dir_ / "o.png").string() + kTiny, "focus distance");
  expect_clean_failure("render --out " + (dir_ / "o.tiff2").string() + kTiny, "o.tiff2");
  expect_clean_failure("render --aperture-blades 2 --out " + (dir_ / "o.png").string() + kTiny,
                       "aperture blades");
  expect_clean_failure("render --aperture-roundness 1.5 --out " + (dir_ / "o.png").string() +
                           kTiny, "aperture roundness");
  expect_clean_failure("render --anamorphic-ratio 0 --out " + (dir_ / "o.png").string() + kTiny,
                       "anamorphic ratio");
  expect_clean_failure("render --vignetting-stop 0.01,-0.02 --out " + (dir_ / "o.png").string() +
                           kTiny, "vignetting stop");
  expect_clean_failure("render --lateral-ca 0.5 --out " + (dir_ / "o.png").string() + kTiny,
                       "lateral chromatic aberration");
  expect_clean_failure("render --aperture-profile rim --aperture-profile-strength 2 --out " +
                           (dir_ / "o.png").string() + kTiny, "profile strength");
  expect_clean_failure("render --lens-tilt 90,0 --out " + (dir_ / "o.png").string() + kTiny,
                       "tilt must be under 90 degrees");
  expect_clean_failure("render --aperture-image " + (dir_ / "no_such_aperture.png").string() +
                           " --out " + (dir_ / "o.png").string() + kTiny,
                       "no_such_aperture.png");
  expect_clean_failure("sequence " + std::string(DOFCACHE_SOURCE_DIR) +
                           "/scenes/cornell_box_dolly.gltf --frames 0 --persistent --lens-tilt 1,0 "
                           "-o " + (dir_ / "f####.png").string() + kTiny,
                       "--persistent does not follow a tilted lens");
  expect_clean_failure("render --out " + (dir_ / "nodir" / "o.png").string() + kTiny, "o.png");
}

// The loader's limits (docs/reliability.md) on the command line: the built-in Cornell box (a
// sphere among its boxes) is over 10 triangles, so it is refused in one line naming the option
// that raises the limit.
TEST_F(Cli, SceneLimitsAreOptions) {
  const std::string out = " --out " + (dir_ / "o.png").string() + kTiny;
  expect_clean_failure("render --max-triangles 10" + out, "--max-triangles");
  expect_clean_failure("render --max-vertices 10" + out, "--max-vertices");
  expect_clean_failure("sequence --max-triangles 10 --frames 0-0 --out " +
                           (dir_ / "f" / "####.png").string() + kTiny,
                       "--max-triangles");
  EXPECT_EQ(run("render --max-triangles 0" + out).exit_code, 2);  // not a positive number
  EXPECT_EQ(run("render --max-triangles 100000 --max-node-depth 5" + out).exit_code, 0);
}

TEST_F(Cli, CommandLineSyntaxErrorsExitWithTwo) {
  testing::CliResult r = run("render --width 10 --width 20");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_EQ(run("render --no-such-option").exit_code, 2);
  EXPECT_EQ(run("frobnicate").exit_code, 2);
}

TEST_F(Cli, CompareMismatchedSizes) {
  ASSERT_EQ(run("render --out " + (dir_ / "a.exr").string() + kTiny).exit_code, 0);
  ASSERT_EQ(run("render --out " + (dir_ / "b.exr").string() +
                " --width 30 --height 18 --spp 1 --gather-rays 2 -q").exit_code, 0);
  testing::CliResult r = run("compare " + (dir_ / "a.exr").string() + " " + (dir_ / "b.exr").string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
}

}  // namespace
