// The preview driven by the real renderer (preview_renderer.h), and saved inputs refocused
// (inputs_file.h, refocus.h), on small scenes built in code.
#include "dofcache/preview/preview_renderer.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "../render/test_scenes.h"
#include "dofcache/core/error.h"
#include "dofcache/image/image_io.h"
#include "dofcache/preview/inputs_file.h"
#include "dofcache/preview/refocus.h"
#include "dofcache/scene/accel.h"

namespace dofcache::preview {
namespace {

namespace fs = std::filesystem;
using dofcache::testing::add_quad_z;

constexpr int kW = 64, kH = 48;
constexpr float kYfov = 0.5f;
// The front quad covers exactly the pixels [kX0, kX1) x [kY0, kY1): its edges lie on pixel
// boundaries, half a pixel from the nearest pixel centres.
constexpr int kX0 = 16, kX1 = 44, kY0 = 12, kY1 = 34;
constexpr float kFront = 1.0f, kBack = 3.0f;  // depths (metres)

// Camera-space x (y) at depth `d` of the film column (row) boundary `px`.
float film_x(int px, float d) {
  float tan_y = std::tan(0.5f * kYfov), tan_x = tan_y * kW / kH;
  return (2.0f * px / kW - 1.0f) * tan_x * d;
}
float film_y(int py, float d) { return (1.0f - 2.0f * py / kH) * std::tan(0.5f * kYfov) * d; }

bool in_front_quad(int x, int y) { return x >= kX0 && x < kX1 && y >= kY0 && y < kY1; }

// An emissive front quad over an emissive back quad filling the view. Emission only, so the
// colours are exact and noise free. Both quads are one object: only triangle ids tell them apart.
struct TwoQuads {
  scene::Scene scene;
  std::unique_ptr<scene::Accel> accel;
  TwoQuads() {
    scene.materials.push_back(testing::emissive_material({0.9f, 0.2f, 0.1f}));  // front
    scene.materials.push_back(testing::emissive_material({0.1f, 0.3f, 0.8f}));  // back
    add_quad_z(scene, film_x(kX0, kFront), film_x(kX1, kFront), film_y(kY1, kFront),
               film_y(kY0, kFront), -kFront, 0, 0);
    add_quad_z(scene, -5.0f, 5.0f, -5.0f, 5.0f, -kBack, 1, 0);
    testing::build_emitters(scene);
    scene.cameras.push_back(testing::origin_camera(kYfov));
    accel = std::make_unique<scene::Accel>(scene);
  }
  render::RenderSettings settings(double fstop, double focus = 1.6) const {
    render::RenderSettings s;
    s.width = kW, s.height = kH, s.spp = 4;
    // Direct light only, so each quad shows exactly its emission: with a bounce, the back quad's
    // specular lobe sees the front quad's unlit back reflect the back quad's own light (0.0006).
    s.shading.bounces = 0;
    s.lens = lens::ThinLens{0.1, fstop, focus};
    s.progress = Progress::Display::Never;
    return s;
  }
  ScenePreview preview(const render::RenderSettings& s, PreviewMethod m,
                       const PreviewOptions& o = {}) const {
    return render_scene_preview(scene, *accel, scene.cameras[0], s, m, o);
  }
};

constexpr PreviewMethod kMethods[] = {PreviewMethod::Gather, PreviewMethod::Scatter,
                                      PreviewMethod::Layered, PreviewMethod::LayeredOcclusion};

void expect_identical(const image::Image& a, const image::Image& b, const std::string& what) {
  ASSERT_TRUE(a.same_shape(b)) << what;
  size_t differ = 0;
  for (size_t i = 0; i < a.data().size(); ++i) differ += a.data()[i] != b.data()[i];
  EXPECT_EQ(differ, 0u) << what;
}

TEST(PreviewRenderer, InFocusEqualsPinholeInEveryMode) {
  TwoQuads q;
  // A pinhole-like aperture (f/2000: CoC far below a pixel) ...
  render::RenderSettings s = q.settings(2000.0);
  render::RenderSettings p = s;
  p.mode = render::Mode::Pinhole;
  image::Image pinhole = render::render(q.scene, *q.accel, q.scene.cameras[0], p).color;
  for (PreviewMethod m : kMethods)
    expect_identical(q.preview(s, m).image, pinhole,
                     std::string("f/2000, ") + preview_method_name(m));

  // ... and a wide one with everything at the focus distance (a quad filling the view).
  scene::Scene flat;
  flat.materials.push_back(testing::emissive_material({0.5f, 0.7f, 0.2f}));
  add_quad_z(flat, -5.0f, 5.0f, -5.0f, 5.0f, -2.0f, 0, 0);
  testing::build_emitters(flat);
  flat.cameras.push_back(testing::origin_camera(kYfov));
  scene::Accel accel(flat);
  s = q.settings(1.0, 2.0);
  p = s;
  p.mode = render::Mode::Pinhole;
  pinhole = render::render(flat, accel, flat.cameras[0], p).color;
  for (PreviewMethod m : kMethods) {
    ScenePreview r = render_scene_preview(flat, accel, flat.cameras[0], s, m);
    expect_identical(r.image, pinhole,
                     std::string("f/1 at the focus distance, ") + preview_method_name(m));
    EXPECT_TRUE(r.inputs.revealed.empty());
  }
}

// The inputs alone are exactly what the full preview was made from.
TEST(PreviewRenderer, InputsAloneEqualThePreviewsInputs) {
  TwoQuads q;
  const render::RenderSettings s = q.settings(1.0);
  const ScenePreview full = q.preview(s, PreviewMethod::LayeredOcclusion);
  const SceneInputs in = render_preview_inputs(q.scene, *q.accel, q.scene.cameras[0], s,
                                               PreviewMethod::LayeredOcclusion);
  expect_identical(in.inputs.color, full.inputs.color, "colour");
  expect_identical(in.inputs.depth, full.inputs.depth, "depth");
  expect_identical(in.inputs.ids, full.inputs.ids, "ids");
  ASSERT_EQ(in.inputs.revealed.size(), full.inputs.revealed.size());
  ASSERT_FALSE(in.inputs.revealed.empty());
  expect_identical(in.inputs.revealed[0].color, full.inputs.revealed[0].color, "revealed");
  EXPECT_EQ(in.timings.postprocess_ms, 0.0);
}

// A draft at half size, upscaled: each pixel is its nearest source pixel (pixel centres mapped
// back: x -> floor((x + 1/2) / 2) for a factor of two; 3 -> 5 columns gives 0,0,1,2,2).
TEST(PreviewRenderer, UpscaledInputsTakeTheNearestPixel) {
  PreviewInputs in;
  in.color = image::Image(3, 2, 3);
  in.depth = image::Image(3, 2, 1);
  in.ids = image::Image(3, 2, 1);
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 3; ++x) {
      in.color.pixel(x, y)[1] = float(10 * y + x);
      in.depth.pixel(x, y)[0] = float(1 + x + 3 * y);
      in.ids.pixel(x, y)[0] = float(100 + x + 3 * y);
    }
  in.imaging.y_resolution = 2;
  const PreviewInputs up = upscale_inputs(in, 5, 4);
  ASSERT_EQ(up.color.width(), 5);
  ASSERT_EQ(up.depth.height(), 4);
  EXPECT_EQ(up.imaging.y_resolution, 4);
  const int sx[5] = {0, 0, 1, 2, 2}, sy[4] = {0, 0, 1, 1};
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 5; ++x) {
      EXPECT_EQ(up.color.pixel(x, y)[1], float(10 * sy[y] + sx[x])) << x << "," << y;
      EXPECT_EQ(up.depth.pixel(x, y)[0], float(1 + sx[x] + 3 * sy[y]));
      EXPECT_EQ(up.ids.pixel(x, y)[0], float(100 + sx[x] + 3 * sy[y]));
    }
  in.revealed.push_back(RevealedLayer{});
  EXPECT_THROW(upscale_inputs(in, 5, 4), Error);
}

class TwoLayerMasks : public ::testing::TestWithParam<bool> {};

// The front quad (c = -3.5 px) over the back quad (c = +2.7 px), f/1 focused at 1.6 m: the back
// quad is revealed in exactly one layer j* (the last near plane in (front, back]); with the lens
// reach (rule 3) only within rho + 1/2 = (c_hi - c_front) / 2 + 1/2 of the quad's outline.
TEST_P(TwoLayerMasks, ExactlyTheExpectedPixels) {
  const bool reach = GetParam();
  TwoQuads q;
  render::RenderSettings s = q.settings(1.0);
  PreviewOptions o;
  o.mask_lens_reach = reach;
  ScenePreview r = q.preview(s, PreviewMethod::LayeredOcclusion, o);
  const LayerPlan plan = plan_layers(r.inputs.depth, r.inputs.imaging, o);
  ASSERT_GE(plan.size(), 3);
  int j_star = -1;
  for (int j = 1; j < plan.size(); ++j)
    if (plan.layers[j].depth > kFront && plan.layers[j].depth <= kBack) j_star = j;
  ASSERT_GT(j_star, 0) << "no near plane between the quads";

  const CocMap coc(r.inputs.imaging, o.max_coc_radius);
  const double c_hi = j_star + 1 < plan.size() ? plan.layers[j_star + 1].signed_coc : coc.k();
  const double reach_px = (c_hi - coc(kFront)) / 2 + 0.5;
  ASSERT_GT(std::abs(reach_px - std::round(reach_px)), 0.05) << "ambiguous ring width";
  ASSERT_LT(reach_px, 0.5 * (kY1 - kY0)) << "the ring must not fill the quad";

  ASSERT_EQ(r.inputs.revealed.size(), 1u);
  const RevealedLayer& a = r.inputs.revealed[0];
  EXPECT_EQ(a.near_depth, plan.layers[j_star].depth);
  int expected_count = 0;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      // Distance from a pixel of the quad to the nearest pixel outside it (straight across).
      int d = std::min(std::min(x - kX0 + 1, kX1 - x), std::min(y - kY0 + 1, kY1 - y));
      bool expected = in_front_quad(x, y) && (!reach || d <= reach_px);
      expected_count += expected;
      ASSERT_EQ(a.mask.at(x, y, 0), expected ? 1.0f : 0.0f) << x << "," << y;
      if (!expected) continue;
      // The revealed colour and depth are the back quad's.
      EXPECT_NEAR(a.depth.at(x, y, 0), kBack, 1e-4) << x << "," << y;
      EXPECT_FLOAT_EQ(a.color.at(x, y, 2), 0.8f) << x << "," << y;
    }
  EXPECT_EQ(r.timings.revealed_pixels, static_cast<std::uint64_t>(expected_count));
  EXPECT_EQ(r.timings.revealed_layers, 1);
  // The id layers trace only the clipped pixels the masks read (lens_reach_regions): with the
  // lens reach, the rings; without it, every clipped pixel of every plane in front of the back
  // quad (a plane behind every surface has nothing to trace).
  std::uint64_t clipped = 0;
  for (int j = 1; j < plan.size(); ++j)
    if (plan.layers[j].depth <= kBack)
      for (float z : r.inputs.depth.data()) clipped += z < plan.layers[j].depth * (1 + 1e-4);
  if (reach) {
    EXPECT_LT(r.timings.id_pixels, clipped / 2);
  } else {
    EXPECT_EQ(r.timings.id_pixels, clipped);
  }
  EXPECT_GT(r.timings.pinhole_render_ms, 0.0);
  EXPECT_GT(r.timings.id_render_ms, 0.0);
  EXPECT_GT(r.timings.extra_render_ms, 0.0);
  EXPECT_GT(r.timings.postprocess_ms, 0.0);
  // Triangle ids: the pinhole ids are the front and back quads' triangles (0, 1 and 2, 3).
  EXPECT_LE(r.inputs.ids.at(kW / 2, kH / 2, 0), 1.0f);
  EXPECT_GE(r.inputs.ids.at(2, 2, 0), 2.0f);
}

INSTANTIATE_TEST_SUITE_P(LensReach, TwoLayerMasks, ::testing::Bool());

class SavedInputs : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("dofcache_preview_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(SavedInputs, RefocusWithTheSameLensEqualsTheDirectPreview) {
  TwoQuads q;
  render::RenderSettings s = q.settings(1.0);
  PreviewOptions o;
  ScenePreview r = q.preview(s, PreviewMethod::LayeredOcclusion, o);
  ASSERT_FALSE(r.inputs.revealed.empty());
  const std::string path = (dir_ / "inputs.exr").string();
  save_preview_inputs(path, r.inputs, r.coverage, o);
  SavedPreviewInputs loaded = load_preview_inputs(path);

  expect_identical(loaded.inputs.color, r.inputs.color, "colour");
  expect_identical(loaded.inputs.depth, r.inputs.depth, "depth");
  expect_identical(loaded.inputs.ids, r.inputs.ids, "ids");
  ASSERT_EQ(loaded.inputs.revealed.size(), r.inputs.revealed.size());
  expect_identical(loaded.inputs.revealed[0].mask, r.inputs.revealed[0].mask, "mask");
  EXPECT_EQ(loaded.coverage.near_depth, r.coverage.near_depth);
  EXPECT_EQ(loaded.coverage.far_depth, r.coverage.far_depth);
  EXPECT_EQ(loaded.options.max_layers, o.max_layers);

  RefocusedInputs again =
      refocus_inputs(loaded.inputs, loaded.coverage, loaded.inputs.imaging.lens, loaded.options);
  EXPECT_TRUE(again.warning.empty()) << again.warning;
  for (PreviewMethod m : kMethods)
    expect_identical(render_preview(again.inputs, m, loaded.options),
                     render_preview(r.inputs, m, o),
                     std::string("refocus ") + preview_method_name(m));
  expect_identical(render_preview(again.inputs, PreviewMethod::LayeredOcclusion, o), r.image,
                   "refocus against render_scene_preview");
}

// A lens that is not plain keeps every value of its character through the file, so refocus
// draws the same bokeh; a plain lens writes none of them.
TEST_F(SavedInputs, TheLensCharacterRoundTrips) {
  TwoQuads q;
  render::RenderSettings s = q.settings(1.4);
  lens::ApertureShape& a = s.lens.aperture;
  a.blades = 7, a.rotation_deg = 12.5, a.roundness = 0.25, a.anamorphic_ratio = 1.3;
  a.stop = {0.02, 0.03}, a.axial_ca = 0.05, a.lateral_ca = -0.01;
  a.profile = lens::ApertureProfile::Rim, a.profile_strength = 0.4;
  a.tilt_x_deg = 3, a.tilt_y_deg = -1, a.shift_x = 0.1, a.shift_y = 0.05;
  ScenePreview r = q.preview(s, PreviewMethod::Layered);
  const std::string path = (dir_ / "shaped.exr").string();
  save_preview_inputs(path, r.inputs, r.coverage);
  SavedPreviewInputs loaded = load_preview_inputs(path);
  EXPECT_TRUE(loaded.inputs.imaging.lens == s.lens);
  expect_identical(render_preview(loaded.inputs, PreviewMethod::Layered, {}), r.image, "shaped");
  ScenePreview plain = q.preview(q.settings(1.4), PreviewMethod::Layered);
  save_preview_inputs(path, plain.inputs, plain.coverage);
  EXPECT_TRUE(load_preview_inputs(path).inputs.imaging.lens.aperture.plain());
  // A real lens's equivalent carries its rims (lens/lens_rims.h) instead of a stop.
  render::RenderSettings rims = q.settings(1.4);
  rims.lens.aperture.blades = 6;
  rims.lens.aperture.rims = {{0.03, 0.04}, {0.025, 0.02}, true};
  ScenePreview cut = q.preview(rims, PreviewMethod::Layered);
  save_preview_inputs(path, cut.inputs, cut.coverage);
  loaded = load_preview_inputs(path);
  EXPECT_TRUE(loaded.inputs.imaging.lens == rims.lens);
  expect_identical(render_preview(loaded.inputs, PreviewMethod::Layered, {}), cut.image, "rims");
}

TEST_F(SavedInputs, AnotherLensReslicesAndWarnsOutsideTheRange) {
  TwoQuads q;
  ScenePreview r = q.preview(q.settings(1.0), PreviewMethod::LayeredOcclusion);
  const std::string path = (dir_ / "inputs.exr").string();
  save_preview_inputs(path, r.inputs, r.coverage);
  SavedPreviewInputs loaded = load_preview_inputs(path);

  // Focused on the front quad: the new layers start behind the old z_1 and end before the old
  // last layer, with a smaller aperture: covered, no warning. The back quad is still revealed.
  RefocusedInputs in =
      refocus_inputs(loaded.inputs, loaded.coverage, lens::ThinLens{0.1, 1.2, 1.4}, loaded.options);
  EXPECT_TRUE(in.warning.empty()) << in.warning;
  EXPECT_FALSE(in.inputs.revealed.empty());
  for (const RevealedLayer& l : in.inputs.revealed) {
    bool found = false;
    for (const PreviewLayer& p : in.plan.layers) found = found || p.depth == l.near_depth;
    EXPECT_TRUE(found);
  }
  image::Image img = render_preview(in.inputs, PreviewMethod::LayeredOcclusion, loaded.options);
  EXPECT_EQ(img.width(), kW);

  // Nothing lies behind the back quad: the coverage extends to infinity.
  EXPECT_TRUE(std::isinf(loaded.coverage.far_depth));
  // A much wider aperture: layers closer together, the first in front of the covered range.
  in =
      refocus_inputs(loaded.inputs, loaded.coverage, lens::ThinLens{0.1, 0.2, 1.6}, loaded.options);
  ASSERT_GE(in.plan.size(), 2);
  ASSERT_LT(in.plan.layers[1].depth, loaded.coverage.near_depth);
  EXPECT_NE(in.warning.find("cover"), std::string::npos) << in.warning;
  EXPECT_NE(in.warning.find("aperture"), std::string::npos) << in.warning;
  EXPECT_EQ(in.warning.find('\n'), std::string::npos);

  // Inputs saved without the occlusion fix have nothing to offer.
  ScenePreview k = q.preview(q.settings(1.0), PreviewMethod::Layered);
  EXPECT_FALSE(k.coverage.present);
  in = refocus_inputs(k.inputs, k.coverage, k.inputs.imaging.lens, {});
  EXPECT_NE(in.warning.find("no revealed layers"), std::string::npos) << in.warning;

  EXPECT_THROW(refocus_inputs(loaded.inputs, loaded.coverage, lens::ThinLens{0.1, -1.0, 2.0}, {}),
               Error);
}

TEST_F(SavedInputs, BadFilesAreOneLineErrors) {
  const std::string missing = (dir_ / "missing.exr").string();
  EXPECT_THROW(load_preview_inputs(missing), Error);
  const fs::path garbage = dir_ / "garbage.exr";
  std::ofstream(garbage) << "not an exr at all";
  try {
    load_preview_inputs(garbage.string());
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
  }
  // A valid EXR that is not preview inputs.
  image::write_multipart_exr((dir_ / "other.exr").string(),
                             {{"color", {"R", "G", "B"}, image::Image(4, 4, 3), {}}});
  EXPECT_THROW(load_preview_inputs((dir_ / "other.exr").string()), Error);
}

// An 8x6 set of inputs with one revealed layer of three pixels (row 3, x = 2..4).
PreviewInputs small_inputs() {
  PreviewInputs in;
  in.color = image::Image(8, 6, 3, 0.5f);
  in.depth = image::Image(8, 6, 1, 2.0f);
  in.ids = image::Image(8, 6, 1, 1.0f);
  in.imaging.lens = {0.05, 2.8, 2.0};
  in.imaging.y_resolution = 6;
  RevealedLayer r;
  r.near_depth = 1.5;
  r.color = image::Image(8, 6, 3, 0.25f);
  r.depth = image::Image(8, 6, 1, 3.0f);
  r.mask = image::Image(8, 6, 1, 0.0f);
  for (int x = 2; x < 5; ++x) r.mask.at(x, 3, 0) = 1.0f;
  in.revealed.push_back(r);
  return in;
}

// A revealed pixel at x = 3e9 was converted to int before its range was checked (undefined
// behaviour; UBSan's float-cast-overflow): now refused like any pixel outside the image.
TEST_F(SavedInputs, RevealedPixelFarOutsideTheImageIsRefused) {
  const std::string good = (dir_ / "good.exr").string(), bad = (dir_ / "bad.exr").string();
  save_preview_inputs(good, small_inputs(), {true, 1.5, 4.0, 0.05 / 2.8});
  ASSERT_EQ(load_preview_inputs(good).inputs.revealed.size(), 1u);
  for (float x : {3e9f, std::nanf(""), 1e30f}) {
    std::vector<image::ExrPart> parts = image::read_multipart_exr(good);
    for (image::ExrPart& p : parts)
      if (p.name == "revealed.0") p.image.data()[0] = x;  // the first entry's x
    image::write_multipart_exr(bad, parts);
    try {
      load_preview_inputs(bad);
      ADD_FAILURE() << "accepted x = " << x;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("lists a pixel outside the image"), std::string::npos)
          << e.what();
    }
  }
}

// Found by fuzzing (preview_inputs): an attribute value with a line break, quoted in the error
// ("'focal_length' is not a number ('050<newline>000...')"), made a two-line message.
TEST_F(SavedInputs, QuotedValuesKeepTheErrorOnOneLine) {
  const std::string good = (dir_ / "good.exr").string(), bad = (dir_ / "bad.exr").string();
  save_preview_inputs(good, small_inputs(), {true, 1.5, 4.0, 0.05 / 2.8});
  std::vector<image::ExrPart> parts = image::read_multipart_exr(good);
  for (image::ExrPart& p : parts)
    if (p.attributes.count("focal_length")) p.attributes["focal_length"] = "050\n000";
  image::write_multipart_exr(bad, parts);
  try {
    load_preview_inputs(bad);
    ADD_FAILURE() << "accepted";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("'focal_length' is not a number"), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  }
}

// The revealed lists expand to dense layers: the limit counts what the file makes the loader
// allocate, not only what it holds.
TEST_F(SavedInputs, ExpandedLayersCountAgainstTheImageLimit) {
  const std::string path = (dir_ / "inputs.exr").string();
  save_preview_inputs(path, small_inputs(), {true, 1.5, 4.0, 0.05 / 2.8});
  // Read: colour 3 x 48, depth 48, ids 48, one row of 8 revealed entries x 6 = 288 values;
  // expanded: (5 + 5 x 1 layer) x 48 = 480.
  EXPECT_EQ(load_preview_inputs(path, 480).inputs.revealed.size(), 1u);
  try {
    load_preview_inputs(path, 479);
    ADD_FAILURE() << "accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("1 revealed layers of 8x6 exceed the image size limit"),
              std::string::npos) << e.what();
  }
  EXPECT_THROW(load_preview_inputs(path, 287), Error);  // already while reading
}

}  // namespace
}  // namespace dofcache::preview
