// Camera paths: a glTF animation on a camera under an animated, rotated parent (LINEAR, STEP and
// CUBICSPLINE channels, normalised-integer rotations), and JSON keyframe files, against poses
// computed by hand.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <nlohmann/json.hpp>

#include "dofcache/core/error.h"
#include "dofcache/render/setup.h"
#include "dofcache/scene/accel.h"
#include "dofcache/sequence/camera_path.h"

using namespace dofcache;
using namespace dofcache::sequence;
namespace fs = std::filesystem;

namespace {

std::string base64(const std::vector<unsigned char>& bytes) {
  static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (std::size_t i = 0; i < bytes.size(); i += 3) {
    unsigned v = bytes[i] << 16 | (i + 1 < bytes.size() ? bytes[i + 1] << 8 : 0) |
                 (i + 2 < bytes.size() ? bytes[i + 2] : 0);
    out += t[v >> 18 & 63];
    out += t[v >> 12 & 63];
    out += i + 1 < bytes.size() ? t[v >> 6 & 63] : '=';
    out += i + 2 < bytes.size() ? t[v & 63] : '=';
  }
  return out;
}

// A glTF file: node 0 "rig" (translation (0,0,1), rotated 90 degrees about +Y) holds node 1
// "cam" (the camera); node 2 is a triangle. Animation "move":
//   cam translation  LINEAR       t = 0, 1:  (0,0,0) -> (2,0,0)
//   cam rotation     STEP         t = 0, 1:  identity -> 90 degrees about +X  (normalised SHORT)
//   rig translation  CUBICSPLINE  t = 0, 2:  (0,0,1) out-tangent (1,0,0) -> (0,0,3), other
//                                            tangents zero
// Animation "decor" moves only the triangle.
class GltfAnimation : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("dofcache_path_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    std::vector<unsigned char> bin;
    std::vector<std::pair<std::size_t, std::size_t>> views;  // offset, length
    auto put_floats = [&](std::vector<float> f) {
      std::size_t at = bin.size();
      bin.resize(at + 4 * f.size());
      std::memcpy(bin.data() + at, f.data(), 4 * f.size());
      views.push_back({at, 4 * f.size()});
    };
    put_floats({0, 0, 0, 1, 0, 0, 0, 1, 0});                   // 0: triangle
    put_floats({0, 1});                                         // 1: cam times
    put_floats({0, 0, 0, 2, 0, 0});                             // 2: cam translation
    {                                                           // 3: cam rotation (SHORT)
      std::vector<std::int16_t> q = {0, 0, 0, 32767, 23170, 0, 0, 23170};
      std::size_t at = bin.size();
      bin.resize(at + 2 * q.size());
      std::memcpy(bin.data() + at, q.data(), 2 * q.size());
      views.push_back({at, 2 * q.size()});
    }
    put_floats({0, 2});                                         // 4: rig times
    put_floats({0, 0, 0, 0, 0, 1, 1, 0, 0,                      // 5: rig cubic (a, v, b) x 2
                0, 0, 0, 0, 0, 3, 0, 0, 0});
    put_floats({0, 1});                                         // 6: decor times
    put_floats({0, 0, 0, 0, 5, 0});                             // 7: decor translation
    nlohmann::json doc;
    doc["asset"] = {{"version", "2.0"}};
    doc["buffers"] = {{{"byteLength", bin.size()},
                       {"uri", "data:application/octet-stream;base64," + base64(bin)}}};
    for (auto [offset, length] : views)
      doc["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", offset}, {"byteLength", length}});
    auto accessor = [&](int view, int count, const char* type, int component, bool norm = false) {
      nlohmann::json a = {{"bufferView", view}, {"count", count}, {"type", type},
                          {"componentType", component}};
      if (norm) a["normalized"] = true;
      doc["accessors"].push_back(a);
    };
    accessor(0, 3, "VEC3", 5126);
    doc["accessors"][0]["min"] = {0, 0, 0};
    doc["accessors"][0]["max"] = {1, 1, 0};
    accessor(1, 2, "SCALAR", 5126);
    accessor(2, 2, "VEC3", 5126);
    accessor(3, 2, "VEC4", 5122, true);
    accessor(4, 2, "SCALAR", 5126);
    accessor(5, 6, "VEC3", 5126);
    accessor(6, 2, "SCALAR", 5126);
    accessor(7, 2, "VEC3", 5126);
    const double h = std::sqrt(0.5);
    doc["nodes"] = {{{"name", "rig"}, {"translation", {0, 0, 1}}, {"rotation", {0, h, 0, h}},
                     {"children", {1}}},
                    {{"name", "cam"}, {"camera", 0}},
                    {{"name", "tri"}, {"mesh", 0}}};
    doc["cameras"] = {{{"type", "perspective"},
                       {"perspective", {{"yfov", 0.6}, {"znear", 0.01}, {"aspectRatio", 1.5}}}}};
    doc["meshes"] = {{{"primitives", {{{"attributes", {{"POSITION", 0}}}}}}}};
    doc["scenes"] = {{{"nodes", {0, 2}}}};
    doc["scene"] = 0;
    doc["animations"] = {
        {{"name", "decor"},
         {"samplers", {{{"input", 6}, {"output", 7}}}},
         {"channels", {{{"sampler", 0}, {"target", {{"node", 2}, {"path", "translation"}}}}}}},
        {{"name", "move"},
         {"samplers", {{{"input", 1}, {"output", 2}, {"interpolation", "LINEAR"}},
                       {{"input", 1}, {"output", 3}, {"interpolation", "STEP"}},
                       {{"input", 4}, {"output", 5}, {"interpolation", "CUBICSPLINE"}}}},
         {"channels", {{{"sampler", 0}, {"target", {{"node", 1}, {"path", "translation"}}}},
                       {{"sampler", 1}, {"target", {{"node", 1}, {"path", "rotation"}}}},
                       {{"sampler", 2}, {"target", {{"node", 0}, {"path", "translation"}}}}}}}};
    file_ = (dir_ / "animated.gltf").string();
    std::ofstream(file_) << doc.dump();
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path dir_;
  std::string file_;
};

void expect_vec(glm::dvec3 got, glm::dvec3 want, double tol = 1e-4) {
  EXPECT_NEAR(got.x, want.x, tol);
  EXPECT_NEAR(got.y, want.y, tol);
  EXPECT_NEAR(got.z, want.z, tol);
}

glm::dvec3 position(const PathSample& s) { return glm::dvec3(s.camera_to_world[3]); }
glm::dvec3 forward(const PathSample& s) { return -glm::dvec3(s.camera_to_world[2]); }
glm::dvec3 up(const PathSample& s) { return glm::dvec3(s.camera_to_world[1]); }

TEST_F(GltfAnimation, ComposesChannelsDownTheHierarchy) {
  scene::Scene sc = render::load_scene(file_);
  ASSERT_EQ(sc.cameras.size(), 1u);
  CameraPath path = load_gltf_camera_path(file_, sc.cameras[0]);  // picks "move", not "decor"
  EXPECT_NE(path.source.find("'move'"), std::string::npos) << path.source;
  EXPECT_DOUBLE_EQ(path.start_time, 0.0);
  EXPECT_DOUBLE_EQ(path.end_time, 2.0);

  // t = 0.5. rig: CUBICSPLINE at s = 0.25, td = 2: h00 = 0.84375, h10 = 0.140625,
  // h01 = 0.15625 -> (2 * 0.140625, 0, 0.84375 * 1 + 0.15625 * 3) = (0.28125, 0, 1.3125).
  // cam: LINEAR translation (1,0,0), STEP rotation still identity. The rig's 90-degree turn about
  // +Y maps local +X to world -Z and the view axis -Z to world -X.
  PathSample a = path.at(0.5);
  expect_vec(position(a), {0.28125, 0.0, 0.3125});
  expect_vec(forward(a), {-1, 0, 0});
  expect_vec(up(a), {0, 1, 0});

  // t = 1. rig at s = 0.5: (2 * 0.125, 0, 0.5 * 1 + 0.5 * 3) = (0.25, 0, 2); cam translation
  // (2,0,0) -> world (0,0,-2); STEP switched to 90 degrees about +X: the view axis turns to +Y,
  // the up axis to +Z, which the rig turns to +X.
  PathSample b = path.at(1.0);
  expect_vec(position(b), {0.25, 0.0, 0.0});
  expect_vec(forward(b), {0, 1, 0});
  expect_vec(up(b), {1, 0, 0});

  // Past the end every channel holds its last value: rig (0,0,3), cam (2,0,0) -> (0,0,1).
  expect_vec(position(path.at(5.0)), {0.0, 0.0, 1.0});
  // The rest pose of the file matches the loader's camera (t = 0: all channels at key 0).
  glm::dmat4 c0 = path.at(0.0).camera_to_world;
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) EXPECT_NEAR(c0[c][r], sc.cameras[0].camera_to_world[c][r], 1e-6);
}

TEST_F(GltfAnimation, SelectsAnimationsAndFrames) {
  scene::Scene sc = render::load_scene(file_);
  CameraPath by_index = load_gltf_camera_path(file_, sc.cameras[0], "1");
  EXPECT_NE(by_index.source.find("'move'"), std::string::npos);
  EXPECT_THROW(load_gltf_camera_path(file_, sc.cameras[0], "decor"), Error);  // moves no camera
  EXPECT_THROW(load_gltf_camera_path(file_, sc.cameras[0], "nope"), Error);
  EXPECT_EQ(path_frame_range(by_index, 24.0), std::make_pair(0, 48));
  EXPECT_EQ(path_frame_range(by_index, 2.5), std::make_pair(0, 5));

  scene::Accel accel(sc);
  render::LensOverrides o;
  o.focus_distance = 2.0;
  std::vector<FrameSpec> frames = plan_frames(sc, accel, sc.cameras[0], by_index, 2.0, 1, 2, o);
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[0].number, 1);
  EXPECT_DOUBLE_EQ(frames[0].time, 0.5);
  EXPECT_NEAR(frames[0].camera.camera_to_world[3][0], 0.28125, 1e-5);
  EXPECT_DOUBLE_EQ(frames[0].lens.focus_distance, 2.0);
  EXPECT_THROW(plan_frames(sc, accel, sc.cameras[0], by_index, 2.0, 3, 1, o), Error);
}

TEST_F(GltfAnimation, RefusesBrokenAnimations) {
  scene::Scene sc = render::load_scene(file_);
  nlohmann::json doc = nlohmann::json::parse(std::ifstream(file_));
  auto rewrite = [&](const nlohmann::json& d) {
    std::ofstream(file_) << d.dump();
  };
  nlohmann::json bad = doc;
  bad["animations"][1]["samplers"][0]["interpolation"] = "BEZIER";
  rewrite(bad);
  EXPECT_THROW(load_gltf_camera_path(file_, sc.cameras[0]), Error);
  bad = doc;
  bad["animations"][1]["samplers"][0]["output"] = 5;  // 6 values for 2 LINEAR keys
  rewrite(bad);
  EXPECT_THROW(load_gltf_camera_path(file_, sc.cameras[0]), Error);
  bad = doc;
  bad["animations"][1]["channels"][0]["sampler"] = 9;
  rewrite(bad);
  EXPECT_THROW(load_gltf_camera_path(file_, sc.cameras[0]), Error);
  bad = doc;
  bad["accessors"][2]["count"] = 200;  // reads past the buffer view
  rewrite(bad);
  EXPECT_THROW(load_gltf_camera_path(file_, sc.cameras[0]), Error);
  bad = doc;
  bad.erase("animations");
  rewrite(bad);
  try {
    load_gltf_camera_path(file_, sc.cameras[0]);
    ADD_FAILURE() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no animations"), std::string::npos) << e.what();
  }
}

// The rest pose of the camera's chain is read by the scene's glTF document layer, which validates
// node transforms as the scene loader does: a malformed one is refused (camera paths once
// ignored a translation, rotation or scale of the wrong length), and so is an accessor of the
// wrong type (a rotation output must be VEC4, not any type of 4 components).
TEST_F(GltfAnimation, RefusesMalformedRestTransformsAndAccessorTypes) {
  scene::Scene sc = render::load_scene(file_);
  const nlohmann::json doc = nlohmann::json::parse(std::ifstream(file_));
  auto error_of = [&](const nlohmann::json& d) -> std::string {
    std::ofstream(file_) << d.dump();
    try {
      load_gltf_camera_path(file_, sc.cameras[0]);
    } catch (const Error& e) {
      return e.what();
    }
    return "no error";
  };
  const std::pair<const char*, nlohmann::json> malformed[] = {
      {"translation", nlohmann::json::array({0, 0})},
      {"rotation", nlohmann::json::array({0, 0, 1})},
      {"scale", nlohmann::json::array({1, 1, 1, 1})}};
  for (const auto& [key, value] : malformed) {
    nlohmann::json bad = doc;
    bad["nodes"][0][key] = value;  // the rig, the camera's parent
    const std::string what = error_of(bad);
    EXPECT_NE(what.find("node 'rig' (0): " + std::string(key) + " must have"), std::string::npos)
        << what;
  }
  nlohmann::json bad = doc;
  bad["accessors"][3]["type"] = "MAT2";  // the camera's rotation output: 4 components
  const std::string what = error_of(bad);
  EXPECT_NE(what.find("must be of type VEC4"), std::string::npos) << what;
  std::ofstream(file_) << doc.dump();
  EXPECT_NO_THROW(load_gltf_camera_path(file_, sc.cameras[0]));
}

scene::Camera base_camera() {
  scene::Camera c;
  c.camera_to_world = glm::mat4(1.0f);
  c.camera_to_world[3] = glm::vec4(0.0f, 1.0f, 4.0f, 1.0f);
  c.yfov = 0.7f;
  return c;
}

TEST(KeyframePath, LookAtAndLensTracks) {
  CameraPath p = parse_keyframe_path(R"({
    "dofcache_camera_path": 1, "fps": 10,
    "keys": [
      {"frame": 0,  "position": [0, 0, 5], "target": [0, 0, 0], "focus_distance": 5, "fstop": 2},
      {"frame": 10, "position": [1, 0, 5], "target": [1, 0, 0], "focus_distance": 3},
      {"time": 2.0, "position": [1, 0, 5], "target": [1, 1, 0]}
    ]})", "test.json", base_camera());
  EXPECT_DOUBLE_EQ(*p.fps, 10.0);
  EXPECT_DOUBLE_EQ(p.start_time, 0.0);
  EXPECT_DOUBLE_EQ(p.end_time, 2.0);
  PathSample s = p.at(0.5);  // frame 5: halfway between the first two keys
  expect_vec(position(s), {0.5, 0, 5}, 1e-12);
  expect_vec(forward(s), {0, 0, -1}, 1e-12);
  expect_vec(up(s), {0, 1, 0}, 1e-12);
  EXPECT_DOUBLE_EQ(*s.focus_distance, 4.0);
  EXPECT_DOUBLE_EQ(*s.fstop, 2.0);  // one key: constant
  EXPECT_FALSE(s.focal_length.has_value());
  PathSample e = p.at(2.0);  // looking at (1,1,0) from (1,0,5)
  expect_vec(forward(e), glm::normalize(glm::dvec3(0, 1, -5)), 1e-12);
  EXPECT_DOUBLE_EQ(*e.focus_distance, 3.0);
}

TEST(KeyframePath, ApertureShapeAnimates) {
  // Blades hold from key to key; rotation and the anamorphic ratio interpolate.
  CameraPath p = parse_keyframe_path(R"({
    "dofcache_camera_path": 1, "fps": 10,
    "keys": [
      {"frame": 0,  "position": [0, 0, 5], "aperture_blades": 5, "aperture_rotation": 0,
       "anamorphic_ratio": 1, "vignetting_stop": [0.01, 0.02], "axial_ca": 0.0,
       "aperture_profile": "rim", "aperture_profile_strength": 0.2, "lens_tilt": [0, 0],
       "lens_shift": [0.1, 0]},
      {"frame": 10, "position": [1, 0, 5], "aperture_blades": 8, "aperture_rotation": 90,
       "anamorphic_ratio": 2, "vignetting_stop": [0.02, 0.04], "axial_ca": 0.1,
       "aperture_profile": "centre", "aperture_profile_strength": 0.6, "lens_tilt": [4, -2],
       "lens_shift": [0.1, 0.2]}
    ]})", "test.json", base_camera());
  const PathSample s = p.at(0.5);
  EXPECT_EQ(*s.aperture.blades, 5);
  EXPECT_DOUBLE_EQ(*s.aperture.rotation_deg, 45.0);
  EXPECT_DOUBLE_EQ(*s.aperture.anamorphic_ratio, 1.5);
  EXPECT_FALSE(s.aperture.roundness.has_value());
  ASSERT_TRUE(s.aperture.vignetting_stop.has_value());
  EXPECT_NEAR(s.aperture.vignetting_stop->radius, 0.015, 1e-12);
  EXPECT_NEAR(s.aperture.vignetting_stop->distance, 0.03, 1e-12);
  EXPECT_NEAR(*s.aperture.axial_ca, 0.05, 1e-12);
  EXPECT_FALSE(s.aperture.lateral_ca.has_value());
  EXPECT_EQ(*s.aperture.profile, lens::ApertureProfile::Rim);  // held to the next key
  EXPECT_NEAR(*s.aperture.profile_strength, 0.4, 1e-12);
  EXPECT_EQ(*p.at(1.0).aperture.profile, lens::ApertureProfile::Centre);
  ASSERT_TRUE(s.aperture.lens_tilt && s.aperture.lens_shift);
  EXPECT_NEAR(s.aperture.lens_tilt->first, 2.0, 1e-12);
  EXPECT_NEAR(s.aperture.lens_tilt->second, -1.0, 1e-12);
  EXPECT_NEAR(s.aperture.lens_shift->second, 0.1, 1e-12);
  EXPECT_EQ(*p.at(1.0).aperture.blades, 8);
  auto bad = [](const std::string& member) {
    return parse_keyframe_path(R"({"dofcache_camera_path": 1, "keys": [{"time": 0, )" + member +
                                   "}]}",
                               "bad.json", base_camera());
  };
  EXPECT_THROW(bad(R"("aperture_blades": 2)"), Error);
  EXPECT_THROW(bad(R"("aperture_blades": 5.5)"), Error);
  EXPECT_THROW(bad(R"("aperture_roundness": -1)"), Error);
  EXPECT_THROW(bad(R"("anamorphic_ratio": 0)"), Error);
  EXPECT_THROW(bad(R"("vignetting_stop": [0.01, -1])"), Error);
  EXPECT_THROW(bad(R"("vignetting_stop": 0.01)"), Error);
  EXPECT_THROW(bad(R"("lateral_ca": 1)"), Error);
  EXPECT_THROW(bad(R"("aperture_profile": "bubble")"), Error);
  EXPECT_THROW(bad(R"("lens_tilt": [95, 0])"), Error);
  EXPECT_THROW(bad(R"("lens_shift": 0.1)"), Error);
}

TEST(KeyframePath, RotationStepAndSmooth) {
  const double h = std::sqrt(0.5);
  std::string rot = "[0, " + std::to_string(h) + ", 0, " + std::to_string(h) + "]";
  CameraPath step = parse_keyframe_path(
      R"({"dofcache_camera_path": 1, "interpolation": "step", "keys": [
          {"time": 0, "rotation": [0, 0, 0, 1]}, {"time": 1, "rotation": )" + rot + "}]}",
      "step.json", base_camera());
  expect_vec(position(step.at(0.5)), {0, 1, 4}, 1e-6);  // the base camera's position
  expect_vec(forward(step.at(0.99)), {0, 0, -1}, 1e-6);
  expect_vec(forward(step.at(1.0)), {-1, 0, 0}, 1e-5);

  // Smooth, two keys: zero tangents at both ends, so the Hermite weight is 3s^2 - 2s^3.
  CameraPath smooth = parse_keyframe_path(
      R"({"dofcache_camera_path": 1, "interpolation": "smooth", "keys": [
          {"time": 0, "focus_distance": 1}, {"time": 1, "focus_distance": 2}]})",
      "smooth.json", base_camera());
  EXPECT_NEAR(*smooth.at(0.25).focus_distance, 1.0 + 0.15625, 1e-12);
  EXPECT_NEAR(*smooth.at(0.5).focus_distance, 1.5, 1e-12);
  // A pure focus pull keeps the base camera's pose.
  glm::dmat4 m = smooth.at(0.5).camera_to_world;
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) EXPECT_NEAR(m[c][r], base_camera().camera_to_world[c][r], 1e-6);
}

TEST(KeyframePath, RefusesMistakes) {
  auto parse = [](const std::string& keys, const std::string& extra = "") {
    std::string text = R"({"dofcache_camera_path": 1, )" + extra + R"("keys": )" + keys + "}";
    return parse_keyframe_path(text, "bad.json", base_camera());
  };
  EXPECT_THROW(parse(R"([{"time": 0, "focus": 2}])"), Error);                  // unknown member
  EXPECT_THROW(parse(R"([{"time": 0, "frame": 0, "fstop": 2}])"), Error);      // both times
  EXPECT_THROW(parse(R"([{"fstop": 2}])"), Error);                              // no time
  EXPECT_THROW(parse(R"([{"time": 1, "fstop": 2}, {"time": 0, "fstop": 3}])"), Error);
  EXPECT_THROW(parse(R"([{"time": 0, "target": [0,0,0]}, {"time": 1, "rotation": [0,0,0,1]}])"),
               Error);
  EXPECT_THROW(parse(R"([{"time": 0, "fstop": -2}])"), Error);
  EXPECT_THROW(parse(R"([{"time": 0, "position": [0, 0]}])"), Error);
  EXPECT_THROW(parse(R"([{"time": 0}])"), Error);  // animates nothing
  EXPECT_THROW(parse(R"([])"), Error);
  EXPECT_THROW(parse(R"([{"time": 0, "fstop": 2}])", R"("interpolation": "cubic", )"), Error);
  EXPECT_THROW(parse_keyframe_path(R"({"keys": [{"time": 0, "fstop": 2}]})", "v.json",
                                   base_camera()), Error);  // no format version
  EXPECT_THROW(parse_keyframe_path("{not json", "j.json", base_camera()), Error);
  try {
    parse(R"([{"time": 0, "fstop": 2}, {"time": 1, "focus": 2}])");
  } catch (const Error& e) {
    std::string what = e.what();
    EXPECT_NE(what.find("bad.json: key 1: unknown member 'focus'"), std::string::npos) << what;
  }
  // A target at the camera position is caught when the pose is evaluated.
  CameraPath p = parse(R"([{"time": 0, "position": [0,0,0], "target": [0,0,0]}])");
  EXPECT_THROW(p.at(0.0), Error);
}

// Found by fuzzing (docs/reliability.md): a number beyond double's range made nlohmann::json
// throw out_of_range, which escaped as another exception type than dofcache::Error. The input is
// the one the fuzzer found, reduced to the number.
// Found by fuzzing: a member name holding an escaped newline was quoted into a two-line error.
TEST(KeyframePath, QuotedMemberNameWithANewlineIsAOneLineError) {
  try {
    parse_keyframe_path(R"({"dofcache_camera_path": 1, "keys": [
        {"time": 0, "focus_dist\nce": 3}]})", "newline.json", base_camera());
    ADD_FAILURE() << "accepted";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    EXPECT_NE(what.find("unknown member 'focus_dist"), std::string::npos) << what;
  }
}

TEST(KeyframePath, NumberBeyondDoubleRangeIsAOneLineError) {
  try {
    parse_keyframe_path(R"({"dofcache_camera_path": 1, "keys": [
        {"time": 0, "position": [0, 0, 3], "rotation": [0, 0, 0, 1e3081]}]})",
                        "overflow.json", base_camera());
    ADD_FAILURE() << "accepted";
  } catch (const Error& e) {
    std::string what = e.what();
    EXPECT_NE(what.find("overflow.json: invalid JSON: number overflow parsing '1e3081'"),
              std::string::npos) << what;
  }
}

// `dofcache view`'s "append keyframe": a new file gets the camera's pose and lens as key 0; the
// next key comes one second (24 frames) later; the path read back passes through both poses.
TEST(KeyframePath, AppendedKeysReadBackAsThePosesAndLensesGiven) {
  const fs::path dir = fs::temp_directory_path() / ("dofcache_append_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string file = (dir / "keys.json").string();
  scene::Camera a = base_camera();
  a.camera_to_world = glm::translate(glm::mat4(1.0f), glm::vec3(1, 2, 3));
  scene::Camera b = a;  // turned 90 degrees left (about +Y): looks down -X
  b.camera_to_world = glm::rotate(a.camera_to_world, float(M_PI / 2), glm::vec3(0, 1, 0));
  b.yfov = 0.5f;
  EXPECT_EQ(append_keyframe(file, a, lens::ThinLens{0.05, 2.0, 4.0}, "test"), 1);
  EXPECT_EQ(append_keyframe(file, b, lens::ThinLens{0.08, 5.6, 2.5}), 2);
  const CameraPath p = load_keyframe_path(file, base_camera());
  EXPECT_DOUBLE_EQ(*p.fps, 24.0);
  EXPECT_DOUBLE_EQ(p.start_time, 0.0);
  EXPECT_DOUBLE_EQ(p.end_time, 1.0);
  const PathSample s0 = p.at(0.0), s1 = p.at(1.0);
  expect_vec(position(s0), {1, 2, 3}, 1e-6);
  expect_vec(forward(s0), {0, 0, -1}, 1e-6);
  expect_vec(forward(s1), {-1, 0, 0}, 1e-6);
  EXPECT_NEAR(*s1.yfov, 0.5, 1e-7);
  EXPECT_DOUBLE_EQ(*s0.fstop, 2.0);
  EXPECT_DOUBLE_EQ(*s1.focus_distance, 2.5);
  EXPECT_DOUBLE_EQ(*s1.focal_length, 0.08);

  // A file of look-at keys gets a look-at key (the target on the axis at the focus distance).
  const std::string look = (dir / "look.json").string();
  std::ofstream(look) << R"({"dofcache_camera_path": 1, "fps": 10,
      "keys": [{"frame": 3, "position": [0, 0, 5], "target": [0, 0, 0]}]})";
  EXPECT_EQ(append_keyframe(look, b, lens::ThinLens{0.05, 2.0, 4.0}), 2);
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(look));
  EXPECT_EQ(j["keys"][1]["frame"].get<double>(), 13.0);
  const nlohmann::json& target = j["keys"][1]["target"];
  expect_vec({target[0].get<double>(), target[1].get<double>(), target[2].get<double>()},
             {-3, 2, 3}, 1e-6);
  EXPECT_FALSE(j["keys"][1].contains("rotation"));

  // Not a keyframe file: one line, the file untouched.
  const std::string bad = (dir / "bad.json").string();
  std::ofstream(bad) << "{\"keys\": 3}";
  EXPECT_THROW(append_keyframe(bad, a, lens::ThinLens{0.05, 2.0, 4.0}), Error);
  std::ifstream in(bad);
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(in), {}), "{\"keys\": 3}");
  fs::remove_all(dir);
}

TEST(KeyframePath, ShippedPathsLoad) {
  std::string dir = std::string(DOFCACHE_SOURCE_DIR) + "/scenes/";
  scene::Scene sc = render::load_scene(dir + "cornell_box.gltf");
  CameraPath pull = load_keyframe_path(dir + "paths/cornell_focus_pull.json", sc.cameras[0]);
  EXPECT_FALSE(pull.focus_distance.empty());
  scene::Scene dolly_scene = render::load_scene(dir + "cornell_box_dolly.gltf");
  CameraPath dolly = load_gltf_camera_path(dir + "cornell_box_dolly.gltf", dolly_scene.cameras[0]);
  auto [first, last] = path_frame_range(dolly, 24.0);
  EXPECT_GE(last - first + 1, 24);
  EXPECT_EQ(dolly_scene.content_hash, sc.content_hash);  // the same scene, plus an animation
}

// The walk-through the sequence benchmark renders: 48 frames, the camera moving 4.8 m, and at each
// key the focus on the object the key holds (its centre, from its triangles, at the focus depth).
TEST(KeyframePath, GalleryWalkRacksFocusFromTheSphereToTheRing) {
  std::string dir = std::string(DOFCACHE_SOURCE_DIR) + "/scenes/";
  scene::Scene sc = render::load_scene(dir + "gallery.glb");
  ASSERT_EQ(sc.cameras.size(), 1u);
  CameraPath walk = load_keyframe_path(dir + "paths/gallery_walk.json", sc.cameras[0]);
  auto [first, last] = path_frame_range(walk, 24.0);
  EXPECT_EQ(first, 0);
  EXPECT_EQ(last, 47);
  auto centre = [&](const std::string& material) {
    glm::dvec3 sum(0.0);
    int count = 0;
    for (std::size_t t = 0; t < sc.mesh.triangles.size(); ++t) {
      if (sc.materials[sc.mesh.triangle_material[t]].name != material) continue;
      for (int k = 0; k < 3; ++k) sum += glm::dvec3(sc.mesh.positions[sc.mesh.triangles[t][k]]);
      count += 3;
    }
    EXPECT_GT(count, 0) << material;
    return sum / double(std::max(count, 1));
  };
  const glm::dvec3 sphere = centre("red_glaze"), ring = centre("gold");
  auto depth = [](const PathSample& s, glm::dvec3 p) {
    return glm::dot(p - glm::dvec3(s.camera_to_world[3]), -glm::dvec3(s.camera_to_world[2]));
  };
  for (auto [frame, subject] : {std::pair{0, sphere}, {14, sphere}, {30, ring}, {47, ring}}) {
    PathSample s = walk.at(frame / 24.0);
    ASSERT_TRUE(s.focus_distance.has_value());
    EXPECT_NEAR(*s.focus_distance, depth(s, subject), 0.02) << "frame " << frame;
  }
  const glm::dvec3 start(walk.at(0.0).camera_to_world[3]), end(walk.at(47 / 24.0).camera_to_world[3]);
  EXPECT_NEAR(glm::length(end - start), 4.8, 0.05);
}

TEST(KeepEvery, KeyframesFromTheFirstPlusTheLast) {
  auto numbers = [](int count, int step) {
    std::vector<FrameSpec> frames(count);
    for (int i = 0; i < count; ++i) frames[i].number = 10 + i;
    std::vector<int> out;
    for (const FrameSpec& f : keep_every(frames, step)) out.push_back(f.number);
    return out;
  };
  EXPECT_EQ(numbers(7, 3), (std::vector<int>{10, 13, 16}));      // the last is a keyframe
  EXPECT_EQ(numbers(8, 3), (std::vector<int>{10, 13, 16, 17}));  // the last is added
  EXPECT_EQ(numbers(3, 1), (std::vector<int>{10, 11, 12}));
  EXPECT_EQ(numbers(3, 50), (std::vector<int>{10, 12}));
  EXPECT_EQ(numbers(1, 4), (std::vector<int>{10}));
  EXPECT_THROW(keep_every({}, 0), Error);
}

// A path whose last key lies beyond the frame numbers a sequence counts is one clean error, not a
// conversion out of int's range (found by fuzzing the keyframe reader).
TEST(KeyframePath, FrameRangeBeyondTheLastFrameNumberIsAnError) {
  const std::string keys = R"({"dofcache_camera_path": 1, "keys": [
      {"time": 0, "position": [0, 0, 3]}, {"time": 133333333.5, "position": [1, 1, 3]}]})";
  const CameraPath p = parse_keyframe_path(keys, "far.json", base_camera());
  try {
    path_frame_range(p, 24.0);
    ADD_FAILURE() << "a 3.2e9-frame path was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("beyond frame 999999999"), std::string::npos) << e.what();
  }
  // The same path at 1 fps ends at frame 133333333 (its key at 133333333.5 s): within the bound.
  EXPECT_EQ(path_frame_range(p, 1.0), std::make_pair(0, 133333333));
}

// A real lens on a path with a rack focus: each frame mounts it focused at its own distance, and
// its field of view breathes as a unit-focusing lens's does: the film moves back to focus close,
// so the same film sees a narrower field, tan(yfov / 2) = (h / 2) / V with the image distance V
// of the thick-lens law (1 / a + 1 / V = 1 / f, a measured from the front principal plane).
TEST(KeyframePath, RealLensBreathesAsItsFocusMoves) {
  CameraPath p = parse_keyframe_path(R"({
    "dofcache_camera_path": 1, "fps": 1,
    "keys": [{"frame": 0, "position": [0, 0, 5], "focus_distance": 0.6},
             {"frame": 1, "position": [0, 0, 5], "focus_distance": 10}]})",
                                     "rack.json", base_camera());
  scene::Scene sc = render::load_scene("");
  scene::Accel accel(sc);
  render::LensOverrides o;
  o.real.file = std::string(DOFCACHE_SOURCE_DIR) + "/scenes/lenses/double_gauss_50mm.lens";
  const std::vector<FrameSpec> frames =
      plan_frames(sc, accel, base_camera(), p, 1.0, 0, 1, o, 60, 40);
  ASSERT_EQ(frames.size(), 2u);
  double tan_half[2];
  for (int i = 0; i < 2; ++i) {
    const lens::MountedLens& m = frames[i].real_lens;
    ASSERT_TRUE(m);
    EXPECT_DOUBLE_EQ(m.lens->focus_distance(), i == 0 ? 0.6 : 10.0);
    const lens::CardinalPoints& c = m.lens->cardinal();
    const double a = m.lens->focus_distance() - c.front_principal_z;
    const double v = 1.0 / (1.0 / c.focal_length - 1.0 / a);
    EXPECT_NEAR(m.film_size.y, 0.024, 1e-12);  // 3:2 on the 36 x 24 mm sensor
    tan_half[i] = std::tan(0.5 * m.yfov());
    EXPECT_NEAR(tan_half[i], 0.012 / v, 1e-4 * tan_half[i]);
    // The frame's thin lens is the equivalent the cache and the preview follow.
    EXPECT_NEAR(frames[i].lens.focal_length, c.focal_length, 1e-12);
  }
  // Close focus: the field narrows by V(10 m) / V(0.6 m), about 9 % for this 50 mm lens.
  EXPECT_LT(tan_half[0], 0.93 * tan_half[1]);
  EXPECT_GT(tan_half[0], 0.88 * tan_half[1]);
}

}  // namespace
