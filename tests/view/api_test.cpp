// The request handling of `dofcache view` without the HTTP transport (view::ViewApi), over a
// session that was never started (nothing is rendered): what the fuzz target drives.
#include <algorithm>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "dofcache/view/api.h"
#include "dofcache/view/session.h"
#include "render/test_scenes.h"

namespace dofcache::view {
namespace {

using json = nlohmann::json;
constexpr const char* kToken = "00112233445566778899aabbccddeeff";

scene::Scene one_plane() {
  scene::Scene s;
  s.materials.push_back(testing::emissive_material({0.5f, 0.5f, 0.5f}));
  testing::add_quad_z(s, -5.0f, 5.0f, -5.0f, 5.0f, -2.0f, 0, 0);
  testing::build_emitters(s);
  s.cameras.push_back(testing::origin_camera(0.8f));
  return s;
}

ViewSettings tiny() {
  ViewSettings s;
  s.request.width = 16;
  s.request.height = 16;
  s.reference = false;
  return s;
}

class ViewApiTest : public ::testing::Test {
 protected:
  ViewApiTest() : session(one_plane(), {0.05, 2.0, 2.0, {}, {}}, tiny()), api(session, kToken) {}
  ApiResponse request(const std::string& method, const std::string& path,
                      const std::string& body = "", const std::string& token = kToken) {
    ApiRequest r;
    r.method = method;
    r.path = path;
    r.token_header = token;
    r.body = body;
    return api.handle(r);
  }
  static std::string error_of(const ApiResponse& res) {
    return json::parse(res.body).at("error").get<std::string>();
  }
  ViewSession session;
  ViewApi api;
};

TEST_F(ViewApiTest, TheTokenComesFirst) {
  EXPECT_EQ(request("GET", "/api/lens", "", "").status, 401);
  EXPECT_EQ(request("GET", "/api/lens", "", "wrong").status, 403);
  EXPECT_EQ(request("POST", "/api/lens", R"({"fstop": 4})", "wrong").status, 403);
  EXPECT_DOUBLE_EQ(session.lens().fstop, 2.0);
  ApiRequest by_param;
  by_param.method = "GET";
  by_param.path = "/api/lens";
  by_param.params = {{"token", "wrong"}, {"token", kToken}};  // the first counts, as in HTTP
  EXPECT_EQ(api.handle(by_param).status, 403);
  by_param.params = {{"token", kToken}, {"token", "wrong"}};
  EXPECT_EQ(api.handle(by_param).status, 200);
}

TEST_F(ViewApiTest, RoutesByMethodAndPath) {
  const ApiResponse get = request("GET", "/api/lens");
  ASSERT_EQ(get.status, 200);
  EXPECT_EQ(get.content_type, "application/json");
  EXPECT_DOUBLE_EQ(json::parse(get.body).at("focus_distance").get<double>(), 2.0);
  EXPECT_EQ(request("HEAD", "/api/lens").body, get.body);  // the transport drops the body
  EXPECT_EQ(request("PUT", "/api/lens").status, 404);
  EXPECT_EQ(request("POST", "/api/status").status, 404);
  // The page's menus come from the status: the preview module's names, with their labels.
  const json status = json::parse(request("GET", "/api/status").body);
  const json& methods = status.at("choices").at("methods");
  ASSERT_EQ(methods.size(), 4u);
  EXPECT_EQ(methods.at(1).at("name"), "preview-occlusion");
  EXPECT_EQ(methods.at(1).at("label"), "occlusion fix (layered + revealed layers)");
  EXPECT_EQ(status.at("choices").at("composites").at(1).at("name"), "slabs");
  EXPECT_EQ(request("GET", "/api/lens/").status, 404);
  EXPECT_EQ(request("GET", "/").content_type, "text/html; charset=utf-8");

  const ApiResponse set = request("POST", "/api/lens", R"({"fstop": 4, "method": "gather"})");
  ASSERT_EQ(set.status, 200) << set.body;
  EXPECT_DOUBLE_EQ(session.lens().fstop, 4.0);
  EXPECT_EQ(json::parse(set.body).at("method").get<std::string>(), "preview-gather");
}

// The aperture's shape goes through the lens route; an absurd one is refused and changes nothing.
TEST_F(ViewApiTest, LensRouteSetsTheAperturesShape) {
  const ApiResponse set =
      request("POST", "/api/lens", R"({"aperture_blades": 6, "anamorphic_ratio": 1.5})");
  ASSERT_EQ(set.status, 200) << set.body;
  EXPECT_EQ(session.lens().aperture.blades, 6);
  EXPECT_EQ(json::parse(set.body).at("aperture_blades"), 6);
  EXPECT_DOUBLE_EQ(json::parse(set.body).at("anamorphic_ratio").get<double>(), 1.5);
  const ApiResponse bad = request("POST", "/api/lens", R"({"aperture_blades": 2})");
  EXPECT_EQ(bad.status, 400);
  EXPECT_NE(error_of(bad).find("aperture blades"), std::string::npos) << bad.body;
  EXPECT_EQ(request("POST", "/api/lens", R"({"aperture_blades": 6.5})").status, 400);
  EXPECT_EQ(session.lens().aperture.blades, 6);
  // A vignetting stop, then none again (null).
  const ApiResponse stop = request("POST", "/api/lens", R"({"vignetting_stop": [0.01, 0.02]})");
  ASSERT_EQ(stop.status, 200) << stop.body;
  EXPECT_EQ(json::parse(stop.body).at("vignetting_stop"), json({0.01, 0.02}));
  EXPECT_EQ(request("POST", "/api/lens", R"({"vignetting_stop": [0.01]})").status, 400);
  EXPECT_EQ(request("POST", "/api/lens", R"({"vignetting_stop": null})").status, 200);
  EXPECT_FALSE(session.lens().aperture.vignetting());
  const ApiResponse ca = request("POST", "/api/lens", R"({"axial_ca": 0.02})");
  ASSERT_EQ(ca.status, 200) << ca.body;
  EXPECT_DOUBLE_EQ(json::parse(ca.body).at("axial_ca").get<double>(), 0.02);
  EXPECT_EQ(request("POST", "/api/lens", R"({"lateral_ca": 0.9})").status, 400);
  const ApiResponse rim = request("POST", "/api/lens", R"({"aperture_profile": "rim"})");
  ASSERT_EQ(rim.status, 200) << rim.body;
  EXPECT_EQ(json::parse(rim.body).at("aperture_profile"), "rim");
  EXPECT_EQ(request("POST", "/api/lens", R"({"aperture_profile": "bubble"})").status, 400);
  const ApiResponse tilt = request("POST", "/api/lens", R"({"lens_tilt": [3, 0]})");
  ASSERT_EQ(tilt.status, 200) << tilt.body;
  EXPECT_EQ(json::parse(tilt.body).at("lens_tilt"), json({3.0, 0.0}));
  EXPECT_EQ(request("POST", "/api/lens", R"({"lens_tilt": [90, 0]})").status, 400);
}

// A shipped lens by name through the lens route: its prescription sets the focal length, the
// status lists the shipped lenses, and null goes back to the thin lens.
TEST_F(ViewApiTest, LensRouteMountsAShippedLensAndLeavesIt) {
  const json lenses = json::parse(request("GET", "/api/status").body).at("choices").at("lenses");
  EXPECT_NE(std::find(lenses.begin(), lenses.end(), json("double_gauss_50mm")), lenses.end())
      << lenses;
  const ApiResponse set = request("POST", "/api/lens", R"({"lens_file": "double_gauss_50mm"})");
  ASSERT_EQ(set.status, 200) << set.body;
  const json lens = json::parse(set.body);
  EXPECT_EQ(lens.at("lens_file"), "double_gauss_50mm");
  EXPECT_NEAR(lens.at("focal_length").get<double>(), 0.0504, 0.0002);
  EXPECT_NEAR(lens.at("fstop").get<double>(), 2.02, 0.01);  // f/2 is wider than its widest
  const json status = json::parse(request("GET", "/api/status").body);
  EXPECT_NEAR(status.at("real_lens").at("field_of_view").at(1).get<double>(), 26.5, 1.0)
      << status.at("real_lens");  // 24 mm of film behind about 50 mm
  EXPECT_EQ(request("POST", "/api/lens", R"({"fstop": 1.4})").status, 400);
  const ApiResponse bad = request("POST", "/api/lens", R"({"lens_file": "no_such_lens"})");
  EXPECT_EQ(bad.status, 400);
  EXPECT_NE(error_of(bad).find("nor is it a shipped lens"), std::string::npos) << bad.body;
  EXPECT_EQ(request("POST", "/api/lens", R"({"lens_file": 3})").status, 400);
  const ApiResponse back = request("POST", "/api/lens", R"({"lens_file": null})");
  ASSERT_EQ(back.status, 200) << back.body;
  EXPECT_TRUE(json::parse(back.body).at("lens_file").is_null());
  EXPECT_FALSE(session.status().real_lens);
  EXPECT_NEAR(session.lens().focal_length, 0.0504, 0.0002);  // the lens it looked through
}

// Before the first inputs: images are 503, pixels 400, both with a message.
TEST_F(ViewApiTest, NothingToShowBeforeTheFirstInputs) {
  ApiRequest image;
  image.method = "GET";
  image.path = "/api/image";
  image.token_header = kToken;
  image.params = {{"kind", "preview"}, {"format", "raw"}};
  EXPECT_EQ(api.handle(image).status, 503);
  ApiRequest depth = image;
  depth.path = "/api/depth";
  depth.params = {{"x", "1"}, {"y", "1"}};
  const ApiResponse d = api.handle(depth);
  EXPECT_EQ(d.status, 400);
  EXPECT_EQ(error_of(d), "no pinhole inputs yet");
  EXPECT_EQ(request("POST", "/api/focus", R"({"x": 1, "y": 1})").status, 400);
}

// Error answers are valid JSON of one line whatever the request quotes.
TEST_F(ViewApiTest, ErrorAnswersAreOneLineOfValidJson) {
  const std::string key = std::string(63, 'k') + "\xC3\xA9";  // cut at 64 bytes inside the é
  const ApiResponse cut = request("POST", "/api/lens", "{\"" + key + "\": 1}");
  EXPECT_EQ(cut.status, 400);
  EXPECT_EQ(error_of(cut), "unknown key '" + std::string(63, 'k') + "\xEF\xBF\xBD'");
  const ApiResponse lines = request("POST", "/api/lens", R"({"method": "a\nb"})");
  EXPECT_EQ(lines.status, 400);
  EXPECT_EQ(error_of(lines).find('\n'), std::string::npos);
  EXPECT_EQ(error_of(ViewApi::error(400, "x\xFF")), "x\xEF\xBF\xBD");
}

}  // namespace
}  // namespace dofcache::view
