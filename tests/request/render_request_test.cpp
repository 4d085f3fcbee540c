// The render request: its names, its JSON form (round trip, one-line errors naming the key) and
// resolve()'s automatic rules, against values worked out by hand from the rules' statements.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "dofcache/core/error.h"
#include "dofcache/core/threads.h"
#include "dofcache/render/setup.h"
#include "dofcache/request/render_request.h"
#include "dofcache/request/resolve.h"
#include "dofcache/scene/accel.h"

using namespace dofcache;
using namespace dofcache::request;

namespace {

std::string error_of(const nlohmann::json& j) {
  try {
    request_from_json(j);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(RequestNames, ModesSpellAsTheCommandLineAndParseBack) {
  EXPECT_EQ(mode_names(), (std::vector<std::string>{"pinhole", "drt", "accumulation", "preview",
                                                     "preview-occlusion", "preview-gather",
                                                     "preview-scatter"}));
  for (const std::string& n : mode_names()) EXPECT_EQ(mode_name(parse_mode(n)), n);
  EXPECT_TRUE(integrates_lens(parse_mode("drt")));
  EXPECT_TRUE(integrates_lens(parse_mode("accumulation")));
  EXPECT_FALSE(integrates_lens(parse_mode("pinhole")));
  EXPECT_FALSE(integrates_lens(parse_mode("preview-occlusion")));
  EXPECT_THROW(parse_mode("layered"), Error);  // the older preview names are refocus's, not modes
  // The preview module's one table accepts the older names its files and `refocus` used.
  EXPECT_EQ(preview::parse_preview_method("layered-occlusion"),
            preview::PreviewMethod::LayeredOcclusion);
  EXPECT_STREQ(preview::preview_method_name(preview::PreviewMethod::Gather), "preview-gather");
}

TEST(RequestDefaults, EachKindHasItsOwnDocumentedDefaults) {
  const RenderRequest image = default_request(Kind::Image);
  EXPECT_EQ(image.width, 640);
  EXPECT_EQ(image.out, "dofcache.png");
  EXPECT_EQ(image.cache, "auto");
  EXPECT_EQ(image.cache_settings.sample_quality, 0);
  EXPECT_EQ(image.cache_settings.radius.min_factor, 1.0);
  EXPECT_EQ(image.cache_settings.direct_below, 50.0f);
  EXPECT_EQ(image.cache_settings.direct_cost_ratio, 2.0f);
  const RenderRequest seq = default_request(Kind::Sequence);
  EXPECT_EQ(seq.width, 320);
  EXPECT_EQ(seq.out, "frames/####.png");
  EXPECT_EQ(seq.cache_settings.sample_quality, 4);
  EXPECT_EQ(seq.cache_settings.radius.min_factor, 0.5);
  EXPECT_EQ(seq.cache_settings.direct_below, 0.0f);
  EXPECT_EQ(seq.cache_settings.direct_cost_ratio, 0.0f);
  EXPECT_EQ(default_request(Kind::View).core_policy, CorePolicy::LeaveOneCore);
  EXPECT_EQ(default_request(Kind::View).cache_settings.direct_cost_ratio, 0.0f);
}

TEST(RequestJson, RoundTripsEveryField) {
  RenderRequest r = default_request(Kind::Sequence);
  r.scene = "a b.gltf";
  r.camera = "cam";
  r.scene_index = 2;
  r.limits.max_triangles = 1234;
  r.width = 48;
  r.height = 36;
  r.spp = 12;
  r.mode = parse_mode("accumulation");
  r.seed = 1ull << 62;
  r.threads = 3;
  r.lens.fstop = 2.8;
  r.shading = render::ShadingSettings{};
  r.shading->bounces = 3;
  r.environment.color = glm::vec3(0.5f, 0.25f, 1.0f);
  r.environment.visible = false;
  r.cache = "octree";
  r.cache_settings.radius.rule = cache::RadiusRule::Adaptive;
  r.cache_settings.direct_below = 7.5f;
  r.cache_settings.direct_cost_ratio = 1.25f;
  r.adaptive = Choice::On;
  r.adaptive_settings.max_factor = 3.0f;
  r.composite = preview::LayerComposite::Slabs;
  r.denoise = Choice::Off;
  r.edge_rays = 9;
  r.stats_json = "s.json";
  r.sequence.frames = "3-9";
  r.sequence.fps = 30.0;
  r.sequence.persistent = true;
  r.sequence.cache_in = "in.vdb";
  const nlohmann::json j = to_json(r);
  const RenderRequest back = request_from_json(nlohmann::json::parse(j.dump()));
  EXPECT_EQ(to_json(back), j);
  EXPECT_EQ(back.seed, 1ull << 62);
  EXPECT_EQ(*back.spp, 12);
  EXPECT_EQ(back.shading->bounces, 3);
  EXPECT_FALSE(back.lens.focus_distance.has_value());
  EXPECT_EQ(*back.lens.fstop, 2.8);
  EXPECT_EQ(back.environment.color->z, 1.0f);
  EXPECT_EQ(back.cache_settings.radius.rule, cache::RadiusRule::Adaptive);
  EXPECT_EQ(back.composite, preview::LayerComposite::Slabs);
  EXPECT_EQ(back.denoise, Choice::Off);
  EXPECT_EQ(back.sequence.frames, "3-9");
  // Absent keys keep the kind's defaults.
  const RenderRequest sparse = request_from_json({{"kind", "sequence"}, {"spp", 2}});
  EXPECT_EQ(sparse.width, 320);
  EXPECT_EQ(*sparse.spp, 2);
}

TEST(RequestJson, BadRequestsAreOneLineErrorsNamingTheKey) {
  EXPECT_NE(error_of({{"cache", {{"min_factr", 1}}}}).find("'cache.min_factr'"), std::string::npos);
  EXPECT_NE(error_of({{"image", {{"width", 0}}}}).find("'image.width' must be in [1, 16384]"),
            std::string::npos);
  EXPECT_NE(error_of({{"spp", 2.5}}).find("whole number"), std::string::npos);
  EXPECT_NE(error_of({{"seed", "1"}}).find("'seed' must be a number"), std::string::npos);
  EXPECT_NE(error_of({{"mode", "blur"}}).find("unknown mode 'blur'"), std::string::npos);
  EXPECT_NE(error_of({{"adaptive", {{"mode", "maybe"}}}}).find("adaptive.mode"), std::string::npos);
  EXPECT_NE(error_of({{"sequence", {{"frames", "1-2"}}}}).find("kind sequence"), std::string::npos);
  EXPECT_NE(error_of(nlohmann::json::array()).find("must be an object"), std::string::npos);
  EXPECT_EQ(error_of({{"choices", {"ignored"}}}), "");  // what --print-request adds
  // An unknown key found after the request is filled: under the sanitizers this also checks that
  // the half-read request (a path too long for the short-string buffer) is freed.
  EXPECT_EQ(error_of({{"scene", {{"path", std::string(40, 's')}}}, {"cacheive", 1}}),
            "request: unknown key 'cacheive'");
}

TEST(Threads, ZeroMeansTheAvailableCoresUnderThePolicy) {
  const int cores = available_cores();
  EXPECT_GE(cores, 1);
  EXPECT_EQ(resolve_threads(0), cores);
  EXPECT_EQ(resolve_threads(0, CorePolicy::LeaveOneCore), std::max(1, cores - 1));
  EXPECT_EQ(resolve_threads(3, CorePolicy::LeaveOneCore), 3);
}

class Resolve : public ::testing::Test {
 protected:
  Resolve() : scene(render::load_scene("")), accel(scene), camera(scene.camera_or_first("")) {}
  ResolvedRequest resolved(RenderRequest r) {
    r.out = "";  // no output checks for these
    if (r.kind == Kind::Image) r.out = "x.png";
    return resolve(r, scene, accel, camera);
  }
  scene::Scene scene;
  scene::Accel accel;
  const scene::Camera& camera;
};

TEST_F(Resolve, AutoRulesAsDocumented) {
  RenderRequest r = default_request(Kind::Image);
  r.width = 64;
  ResolvedRequest drt = resolved(r);
  EXPECT_EQ(drt.cache_backend, "vdb");
  EXPECT_TRUE(drt.settings.adaptive.enabled);
  EXPECT_EQ(drt.settings.spp, 16);
  EXPECT_EQ(drt.settings.height, 48);  // the built-in camera is 4:3
  EXPECT_EQ(drt.settings.cache.sample_quality, 1);  // round(16 / 16)
  EXPECT_EQ(drt.settings.threads, available_cores());
  EXPECT_FALSE(drt.choices.empty());

  r.spp = 256;
  EXPECT_EQ(resolved(r).settings.cache.sample_quality, 16);  // round(256 / 16)
  r.spp.reset();

  r.mode = parse_mode("accumulation");
  ResolvedRequest acc = resolved(r);
  EXPECT_EQ(acc.cache_backend, "vdb");
  EXPECT_FALSE(acc.settings.adaptive.enabled);

  r.mode = parse_mode("preview-occlusion");
  ResolvedRequest pv = resolved(r);
  EXPECT_EQ(pv.cache_backend, "none");
  EXPECT_EQ(pv.settings.spp, 1);
  EXPECT_EQ(pv.settings.shading.light_samples, 1);
  EXPECT_EQ(pv.settings.shading.gather_rays, 2);
  EXPECT_EQ(pv.settings.mode, render::Mode::Pinhole);
  ASSERT_TRUE(pv.preview.has_value());
  EXPECT_TRUE(pv.preview_options.denoise);  // auto: on for the preview modes
  EXPECT_EQ(drt.request.denoise, Choice::On);  // an image written as PNG (the fixture's)
  r.cache = "vdb";
  EXPECT_THROW(resolved(r), Error);  // a preview with a cache
  r.cache = "auto";
  r.mode = parse_mode("drt");
  EXPECT_TRUE(drt.settings.lens_features);  // auto: a PNG shows the denoised render
  RenderRequest exr = r;
  exr.out = "x.exr";
  EXPECT_FALSE(resolve(exr, scene, accel, camera).settings.lens_features);  // auto: EXR stays raw
  exr.out = "";
  EXPECT_FALSE(resolve(exr, scene, accel, camera).settings.lens_features);  // a library caller
  r.denoise = Choice::On;
  EXPECT_TRUE(resolved(r).settings.lens_features);  // the guides of the render's denoiser
  r.denoise = Choice::Auto;

  RenderRequest s = default_request(Kind::Sequence);
  EXPECT_EQ(resolved(s).cache_backend, "none");
  s.sequence.persistent = true;
  ResolvedRequest seq = resolved(s);
  EXPECT_EQ(seq.cache_backend, "vdb");
  EXPECT_FALSE(seq.settings.adaptive.enabled);
  EXPECT_EQ(seq.settings.cache.sample_quality, 4);
  s.cache = "none";
  EXPECT_THROW(resolved(s), Error);  // persistent without a cache
  s.cache = "auto";
  s.denoise = Choice::On;
  EXPECT_TRUE(resolved(s).settings.lens_features);  // the frames, denoised one by one
  s.denoise = Choice::Auto;
  RenderRequest frames = s;
  frames.out = "f/####.png";
  EXPECT_TRUE(resolve(frames, scene, accel, camera).settings.lens_features);  // auto: PNG frames
  frames.out = "f/####.exr";
  EXPECT_FALSE(resolve(frames, scene, accel, camera).settings.lens_features);  // EXR: raw

  RenderRequest v = default_request(Kind::View);
  v.spp = 4;
  ResolvedRequest view = resolved(v);
  // The viewer's passes share one cache: the quality of 64 lens samples, round(64 / 16).
  EXPECT_EQ(view.settings.cache.sample_quality, 4);
  EXPECT_EQ(view.settings.threads, std::max(1, available_cores() - 1));
}

TEST_F(Resolve, AResolvedRequestResolvesToItself) {
  RenderRequest r = default_request(Kind::Image);
  r.width = 40;
  r.mode = parse_mode("preview");
  const ResolvedRequest once = resolved(r);
  const ResolvedRequest twice = resolved(once.request);
  EXPECT_EQ(to_json(twice.request), to_json(once.request));
  EXPECT_EQ(twice.settings.spp, once.settings.spp);
  EXPECT_EQ(twice.settings.lens.focus_distance, once.settings.lens.focus_distance);
}

}  // namespace
