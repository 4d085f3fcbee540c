// The preview modes of `dofcache render` and `dofcache refocus`, end to end on a tiny colour-bars
// render: every mode writes its image; refocus reruns the post-process and warns (one line) when
// the new lens leaves what the saved revealed layers cover; bad input gives one error line, a
// non-zero exit and no output file.
#include <gtest/gtest.h>

#include "cli_harness.h"
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "dofcache/image/image_io.h"

namespace fs = std::filesystem;

namespace {

using dofcache::testing::count_lines;
using dofcache::testing::slurp;
int lines(const std::string& s) { return count_lines(s); }

const std::string kScene = std::string(DOFCACHE_SOURCE_DIR) + "/scenes/color_bars.gltf";
const std::string kTiny = " --width 48 --height 36 --spp 1 --gather-rays 2 --light-samples 1 -q";

class PreviewCli : public dofcache::testing::CliTest {
 protected:
  // Saved preview inputs (occlusion fix) of the tiny render, in.exr.
  void save_inputs() {
    dofcache::testing::CliResult r = run("render " + kScene + " --mode preview-occlusion --out " + path("p.png") +
                   " --save-preview-inputs " + path("in.exr") + kTiny);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    ASSERT_TRUE(fs::exists(path("in.exr")));
  }

  // Non-zero exit, one line on stderr starting "dofcache: error:", and `output` not written.
  void expect_clean_failure(const std::string& args, const std::string& output) {
    dofcache::testing::CliResult r = run(args);
    EXPECT_NE(r.exit_code, 0) << args;
    EXPECT_EQ(lines(r.err), 1) << r.err;
    EXPECT_EQ(r.err.rfind("dofcache: error:", 0), 0u) << r.err;
    EXPECT_FALSE(fs::exists(path(output))) << args;
    for (const auto& e : fs::directory_iterator(dir_))  // no temporary left behind either
      EXPECT_EQ(e.path().filename().string().find(".tmp-"), std::string::npos) << e.path();
  }

  // The bytes of the tiny render in preview `mode` with `option value` (expected to succeed).
  std::string render_with(const std::string& mode, const std::string& option,
                          const std::string& value) {
    const std::string out = path(mode + option + "-" + value + ".png");
    dofcache::testing::CliResult r =
        run("render " + kScene + " --mode " + mode + " --out " + out + " " + option + " " + value +
            kTiny);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return slurp(out);
  }
};

// A preview is a quick look: without --spp or shading options its inputs take one sample per
// pixel with cut-down shading (preview::quick_input_shading); given options are respected.
TEST_F(PreviewCli, QuickInputsByDefaultAndGivenOptionsRespected) {
  auto stats = [&](const std::string& options) {
    const std::string json = path("s.json");
    dofcache::testing::CliResult r = run("render " + kScene + " --mode preview --width 32 -q --out " +
                                         path("p.png") + " --stats-json " + json + options);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return slurp(json);
  };
  const std::string quick = stats("");
  EXPECT_NE(quick.find("\"spp\": 1,"), std::string::npos) << quick;
  EXPECT_NE(quick.find("\"gather_rays\": 2,"), std::string::npos) << quick;
  EXPECT_NE(quick.find("\"light_samples\": 1,"), std::string::npos) << quick;
  const std::string asked = stats(" --spp 3 --gather-rays 5");
  EXPECT_NE(asked.find("\"spp\": 3,"), std::string::npos) << asked;
  EXPECT_NE(asked.find("\"gather_rays\": 5,"), std::string::npos) << asked;
  EXPECT_NE(asked.find("\"light_samples\": 4,"), std::string::npos) << asked;  // the default
}

TEST_F(PreviewCli, EveryPreviewModeWritesAnImage) {
  for (const char* mode : {"preview", "preview-occlusion", "preview-gather", "preview-scatter"}) {
    const std::string out = path(std::string(mode) + ".png");
    dofcache::testing::CliResult r = run("render " + kScene + " --mode " + mode + " --out " + out + kTiny +
                   " --stats-json " + path(std::string(mode) + ".json"));
    ASSERT_EQ(r.exit_code, 0) << mode << ": " << r.err;
    EXPECT_TRUE(fs::exists(out)) << mode;
    EXPECT_NE(r.out.find(out), std::string::npos) << r.out;
    EXPECT_NE(slurp(path(std::string(mode) + ".json")).find("postprocess_ms"), std::string::npos);
  }
  EXPECT_NE(run("render --help").out.find("preview-occlusion"), std::string::npos);
}

TEST_F(PreviewCli, RefocusRerunsThePostProcessAndWarnsOutsideTheRange) {
  save_inputs();
  // The saved lens: nothing to warn about.
  dofcache::testing::CliResult r = run("refocus " + path("in.exr") + " --out " + path("same.png") + " -q");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(fs::exists(path("same.png")));
  EXPECT_EQ(r.err, "");
  // Focused nearer than the saved near planes: one warning line, still an image.
  r = run("refocus " + path("in.exr") +
          " --focus-distance 1.0 --fstop 2 --method layered-occlusion"
          " --out " +
          path("near.png") + " -q");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(fs::exists(path("near.png")));
  EXPECT_EQ(lines(r.err), 1) << r.err;
  EXPECT_EQ(r.err.rfind("dofcache: warning:", 0), 0u) << r.err;
  // The other methods use no revealed layers: no warning.
  r = run("refocus " + path("in.exr") + " --focus-distance 1.0 --method gather --out " +
          path("gather.exr") + " -q");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(fs::exists(path("gather.exr")));
  EXPECT_EQ(r.err, "");
  // Another aperture without re-rendering: the shaped scatter draws it and says so in one line,
  // and the image is not the round lens's.
  r = run("refocus " + path("in.exr") + " --focus-distance 1.0 --method gather --aperture-blades 5"
          " --anamorphic-ratio 1.6 --out " + path("shaped.exr") + " -q");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(lines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find("shaped scatter"), std::string::npos) << r.err;
  const dofcache::image::Image round = dofcache::image::read_image(path("gather.exr"));
  const dofcache::image::Image shaped = dofcache::image::read_image(path("shaped.exr"));
  ASSERT_TRUE(round.same_shape(shaped));
  double diff = 0;
  for (size_t i = 0; i < round.data().size(); ++i) diff += std::abs(round.data()[i] - shaped.data()[i]);
  EXPECT_GT(diff, 1e-3 * static_cast<double>(round.data().size()));
}

TEST_F(PreviewCli, RefocusKeepsARealLensesCatsEyes) {
  // The inputs of a preview through the traced double Gauss carry its rims (lens/lens_rims.h):
  // refocused with the same lens, the image is the direct preview's, cat's eyes and all.
  dofcache::testing::CliResult r =
      run("render " + kScene + " --lens-file double_gauss_50mm --mode preview --out " +
          path("direct.exr") + " --save-preview-inputs " + path("real.exr") + kTiny);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = run("refocus " + path("real.exr") + " --out " + path("again.exr") + " -q");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("shaped scatter"), std::string::npos) << r.err;
  const dofcache::image::Image direct = dofcache::image::read_image(path("direct.exr"));
  const dofcache::image::Image again = dofcache::image::read_image(path("again.exr"));
  ASSERT_TRUE(direct.same_shape(again));
  EXPECT_TRUE(direct.data() == again.data());
}

TEST_F(PreviewCli, BadRefocusInputIsOneLineAndNoFile) {
  save_inputs();
  std::ofstream(path("garbage.exr")) << "this is not an EXR file";
  expect_clean_failure("refocus " + path("garbage.exr") + " --out " + path("o.png"), "o.png");
  expect_clean_failure("refocus " + path("missing.exr") + " --out " + path("o.png"), "o.png");
  // A truncated inputs file.
  {
    std::string bytes = slurp(path("in.exr"));
    std::ofstream(path("cut.exr"), std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  }
  expect_clean_failure("refocus " + path("cut.exr") + " --out " + path("o.png"), "o.png");
  // An EXR that is not preview inputs (an ordinary render).
  ASSERT_EQ(
      run("render " + kScene + " --mode pinhole --out " + path("plain.exr") + kTiny).exit_code, 0);
  expect_clean_failure("refocus " + path("plain.exr") + " --out " + path("o.png"), "o.png");
  // Absurd lenses and outputs.
  expect_clean_failure("refocus " + path("in.exr") + " --fstop -1 --out " + path("o.png"), "o.png");
  expect_clean_failure(
      "refocus " + path("in.exr") + " --focus-distance 0.05 --out " + path("o.png"), "o.png");
  expect_clean_failure("refocus " + path("in.exr") + " --out " + path("o.tiff2"), "o.tiff2");
}

TEST_F(PreviewCli, LayerCompositeChoosesTheComposite) {
  // The default is over; the two composites differ, for both layered methods.
  for (const std::string mode : {"preview", "preview-occlusion"}) {
    const std::string over = render_with(mode, "--layer-composite", "over");
    EXPECT_NE(over, render_with(mode, "--layer-composite", "slabs")) << mode;
    const std::string out = path(mode + "-default.png");
    ASSERT_EQ(run("render " + kScene + " --mode " + mode + " --out " + out + kTiny).exit_code, 0);
    EXPECT_EQ(slurp(out), over) << mode;
  }
  expect_clean_failure("render " + kScene + " --mode preview --layer-composite union --out " +
                           path("o.png") + kTiny,
                       "o.png");
}

TEST_F(PreviewCli, EdgeRaysTraceOnlyTheOcclusionFix) {
  // The fix traces its edge band (16 rays by default); without revealed layers there is nothing
  // to trace, so Kraus & Strengert is the same for any ray count.
  EXPECT_NE(render_with("preview-occlusion", "--edge-rays", "0"),
            render_with("preview-occlusion", "--edge-rays", "16"));
  EXPECT_EQ(render_with("preview", "--edge-rays", "0"), render_with("preview", "--edge-rays", "64"));
  expect_clean_failure("render " + kScene + " --mode preview-occlusion --edge-rays -1 --out " +
                           path("o.png") + kTiny,
                       "o.png");
}

TEST_F(PreviewCli, PreviewOptionMisuseIsOneLineAndNoFile) {
  expect_clean_failure("render " + kScene + " --mode drt --out " + path("o.png") +
                           " --save-preview-inputs " + path("in.exr") + kTiny,
                       "o.png");
  expect_clean_failure("render " + kScene + " --mode preview --out " + path("o.png") +
                           " --save-preview-inputs " + path("in.png") + kTiny,
                       "o.png");
  expect_clean_failure(
      "render " + kScene + " --mode preview --cache vdb --out " + path("o.png") + kTiny, "o.png");
}

}  // namespace
