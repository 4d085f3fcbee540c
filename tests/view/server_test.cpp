// The HTTP API of `dofcache view` (docs/view.md), through the HTTP library's own client against a
// server on a free port: access token, malformed / oversized / abandoned requests and floods,
// focus at a pixel, refocus, the background reference.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <httplib.h>
#include <nlohmann/json.hpp>

#include "dofcache/core/error.h"
#include "dofcache/image/image_io.h"
#include "dofcache/sequence/camera_path.h"
#include "dofcache/view/server.h"
#include "dofcache/view/session.h"
#include "render/test_scenes.h"

namespace dofcache::view {
namespace {

using json = nlohmann::json;
constexpr int kWidth = 64, kHeight = 48;
constexpr float kNear = 1.0f, kFar = 4.0f;

// Camera at the origin looking down -Z. A bright (unsaturated) emissive quad at depth 1 m fills the left half of
// the image (x < 0); a dim emissive wall at depth 4 m fills the rest. Their edge is the middle
// column: sharp when the near quad is in focus, blurred over many pixels when the far wall is.
scene::Scene two_planes() {
  scene::Scene s;
  s.materials.push_back(testing::emissive_material({0.8f, 0.8f, 0.8f}));
  s.materials.push_back(testing::emissive_material({0.2f, 0.2f, 0.2f}));
  testing::add_quad_z(s, -5.0f, 0.0f, -5.0f, 5.0f, -kNear, 0, 0);
  testing::add_quad_z(s, -20.0f, 20.0f, -20.0f, 20.0f, -kFar, 1, 1);
  testing::build_emitters(s);
  s.cameras.push_back(testing::origin_camera(0.8f));
  s.source = "two planes";
  return s;
}

// A 100 mm f/0.5 lens: focused at 4 m, the near quad's circle of confusion is about 8 pixels
// across (eq. (2.4)).
render::LensOverrides wide_open() { return {0.1, 0.5, double(kFar), {}, {}}; }

ViewSettings small_settings(bool reference) {
  ViewSettings s;
  s.request.width = kWidth;
  s.request.height = kHeight;
  s.input_spp = 2;
  s.reference = reference;
  s.reference_pass_spp = 2;
  s.reference_max_spp = 4;
  s.request.shading = render::ShadingSettings{};
  s.request.shading->gather_rays = 2;
  s.request.shading->light_samples = 1;
  return s;
}

class ViewServerTest : public ::testing::Test {
 protected:
  void start(bool reference = false, const std::string& keyframes = "") {
    session = std::make_unique<ViewSession>(two_planes(), wide_open(), small_settings(reference));
    server = std::make_unique<ViewServer>(*session, ServerSettings{0, "", keyframes, "planes", sequence::append_keyframe});
    session->start();
    server->start();
    ASSERT_TRUE(session->wait_for_stage(InputStage::Refined, 60.0));
    client = std::make_unique<httplib::Client>("127.0.0.1", server->port());
    client->set_read_timeout(30, 0);
  }
  void SetUp() override { start(); }
  void TearDown() override {
    if (server) server->stop();
    if (session) session->stop();
  }
  httplib::Headers auth() const { return {{"X-Dofcache-Token", server->token()}}; }
  int get_status(const std::string& path, const httplib::Headers& headers) {
    auto res = client->Get(path.c_str(), headers);
    return res ? res->status : -1;
  }
  httplib::Result post(const std::string& path, const std::string& body) {
    return client->Post(path.c_str(), auth(), body, "application/json");
  }
  bool alive() { return get_status("/api/status", auth()) == 200; }
  // The preview (raw RGBA8) as grey levels of the middle row.
  std::vector<int> middle_row() {
    auto res = client->Get("/api/image?kind=preview&format=raw", auth());
    EXPECT_TRUE(res && res->status == 200);
    if (!res || res->body.size() != std::size_t(kWidth) * kHeight * 4) return {};
    std::vector<int> row(kWidth);
    for (int x = 0; x < kWidth; ++x)
      row[x] = static_cast<unsigned char>(res->body[((kHeight / 2) * kWidth + x) * 4]);
    return row;
  }

  std::unique_ptr<ViewSession> session;
  std::unique_ptr<ViewServer> server;
  std::unique_ptr<httplib::Client> client;
};

// Pixels of the row strictly between the levels 10% and 90% of the way from its darkest to its
// brightest value: the width of the edge's transition.
int transition_width(const std::vector<int>& row) {
  int lo = 255, hi = 0;
  for (int v : row) lo = std::min(lo, v), hi = std::max(hi, v);
  int n = 0;
  for (int v : row) n += v > lo + 0.1 * (hi - lo) && v < lo + 0.9 * (hi - lo);
  return n;
}

// Sends raw bytes on a fresh connection to the server and closes it (without reading).
void send_raw(int port, const std::string& bytes) {
  int fd = socket(AF_INET, SOCK_STREAM, 0);
  ASSERT_GE(fd, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  if (!bytes.empty()) (void)!write(fd, bytes.data(), bytes.size());
  close(fd);
}

TEST_F(ViewServerTest, EveryRequestNeedsTheToken) {
  EXPECT_EQ(get_status("/api/status", {}), 401);
  EXPECT_EQ(get_status("/api/status", {{"X-Dofcache-Token", "0123456789abcdef"}}), 403);
  EXPECT_EQ(get_status("/api/status?token=wrong", {}), 403);
  EXPECT_EQ(get_status("/", {}), 401);
  EXPECT_EQ(get_status("/api/image?kind=preview", {}), 401);
  auto bad = client->Post("/api/lens", R"({"fstop": 2})", "application/json");
  ASSERT_TRUE(bad);
  EXPECT_EQ(bad->status, 401);
  EXPECT_DOUBLE_EQ(session->lens().fstop, 0.5);  // nothing changed

  EXPECT_EQ(get_status("/api/status", auth()), 200);
  auto page = client->Get(("/?token=" + server->token()).c_str());
  ASSERT_TRUE(page);
  EXPECT_EQ(page->status, 200);
  EXPECT_NE(page->body.find("<canvas"), std::string::npos);
  EXPECT_EQ(page->get_header_value("Referrer-Policy"), "no-referrer");
}

TEST_F(ViewServerTest, TokensAreRandomAndTheServerListensOnLoopbackOnly) {
  EXPECT_EQ(server->token().size(), 32u);
  EXPECT_NE(random_token(), random_token());
  EXPECT_EQ(server->url().rfind("http://127.0.0.1:", 0), 0u);
  // The port answers on 127.0.0.1; the server has no way to bind another address.
  EXPECT_GT(server->port(), 0);
  // A port in use is refused, not shared (no SO_REUSEPORT).
  ViewSession other(two_planes(), wide_open(), small_settings(false));
  try {
    ViewServer second(other, ServerSettings{server->port(), "", "", "", {}});
    ADD_FAILURE() << "a second server bound port " << server->port();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cannot bind"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(alive());
}

TEST_F(ViewServerTest, MalformedRequestsAreRefusedAndTheServerKeepsServing) {
  for (const char* body : {"not json", "[1, 2]", "{\"fstop\": \"wide\"}", "{\"fstop\": -1}",
                           "{\"focal_length\": 0.05, \"focus_distance\": 0.01}",
                           "{\"method\": \"magic\"}", "{\"x\": 1}", "{\"x\": -5, \"y\": 3}",
                           "{\"x\": 1e300, \"y\": 3}"}) {
    for (const char* route : {"/api/lens", "/api/focus"}) {
      auto res = post(route, body);
      ASSERT_TRUE(res) << route << " " << body;
      EXPECT_EQ(res->status, 400) << route << " " << body;
      EXPECT_NO_THROW((void)json::parse(res->body).at("error").get<std::string>());
    }
  }
  EXPECT_DOUBLE_EQ(session->lens().fstop, 0.5);
  EXPECT_DOUBLE_EQ(session->lens().focus_distance, kFar);
  EXPECT_EQ(get_status("/api/image?kind=nothing", auth()), 400);
  EXPECT_EQ(get_status("/api/image?kind=preview&format=gif", auth()), 400);
  EXPECT_EQ(get_status("/api/no-such-route", auth()), 404);
  EXPECT_EQ(get_status("/../../etc/passwd", auth()), 404);  // no path reaches the file system
  // A focus outside the image.
  auto outside = post("/api/focus", R"({"x": 64, "y": 0})");
  ASSERT_TRUE(outside);
  EXPECT_EQ(outside->status, 400);

  // Oversized body: refused by its declared length.
  auto big = post("/api/lens", std::string(kMaxRequestBody + 1, ' '));
  ASSERT_TRUE(big);
  EXPECT_EQ(big->status, 413);
  // Garbage, a half-sent request, an oversized header, a connection that sends nothing.
  send_raw(server->port(), "\x16\x03\x01\x02\x00garbage\r\n\r\n");
  send_raw(server->port(), "GET /api/status HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Dofcache-To");
  send_raw(server->port(),
           "GET /api/status HTTP/1.1\r\nX-Long: " + std::string(100000, 'a') + "\r\n\r\n");
  send_raw(server->port(), "");
  send_raw(server->port(), "POST /api/lens HTTP/1.1\r\nContent-Length: 1000000000\r\n\r\n{");
  EXPECT_TRUE(alive());
}

// Error answers quote the request's text, which need not be UTF-8 or one line: a query parameter
// of byte 0xFF, a key cut at its 64th byte inside a two-byte character, a method name holding a
// line break. The JSON writer threw on the first two from inside the server's exception handler,
// which ended the process (found writing the request handling's fuzz target).
TEST_F(ViewServerTest, ErrorsQuotingTextThatIsNotUtf8OrOneLineAreAnswered) {
  auto bad_format = client->Get("/api/image?kind=preview&format=%FF", auth());
  ASSERT_TRUE(bad_format);
  EXPECT_EQ(bad_format->status, 400);
  const std::string message = json::parse(bad_format->body).at("error").get<std::string>();
  EXPECT_NE(message.find("format must be png, exr or raw"), std::string::npos) << message;
  EXPECT_NE(message.find("\xEF\xBF\xBD"), std::string::npos) << message;  // U+FFFD for 0xFF

  auto cut_key = post("/api/lens", "{\"" + std::string(63, 'k') + "\xC3\xA9\": 1}");
  ASSERT_TRUE(cut_key);
  EXPECT_EQ(cut_key->status, 400);
  EXPECT_NE(json::parse(cut_key->body).at("error").get<std::string>().find("unknown key"),
            std::string::npos);

  auto two_lines = post("/api/lens", R"({"method": "layered\nocclusion"})");
  ASSERT_TRUE(two_lines);
  EXPECT_EQ(two_lines->status, 400);
  const std::string folded = json::parse(two_lines->body).at("error").get<std::string>();
  EXPECT_EQ(folded.find('\n'), std::string::npos) << folded;
  EXPECT_NE(folded.find("layered; occlusion"), std::string::npos) << folded;
  EXPECT_TRUE(alive());
}

// Clients that ask for an image and hang up before (or while) it is sent: the server's writes
// fail (no SIGPIPE kills the process) and it keeps serving.
TEST_F(ViewServerTest, ClientsThatDisconnectMidStreamLeaveTheServerRunning) {
  const std::string request = "GET /api/image?kind=preview&format=png HTTP/1.1\r\n"
                              "Host: 127.0.0.1\r\nX-Dofcache-Token: " + server->token() +
                              "\r\n\r\n";
  for (int i = 0; i < 20; ++i) send_raw(server->port(), request);
  // Keep-alive connections with several requests queued, closed at once.
  for (int i = 0; i < 5; ++i) send_raw(server->port(), request + request + request);
  EXPECT_TRUE(alive());
  auto png = client->Get("/api/image?kind=preview&format=png", auth());
  ASSERT_TRUE(png);
  EXPECT_EQ(png->status, 200);
}

TEST_F(ViewServerTest, AFloodOfRequestsLeavesTheServerRunning) {
  std::atomic<int> ok{0}, failed{0};
  std::vector<std::thread> clients;
  for (int t = 0; t < 8; ++t)
    clients.emplace_back([&, t] {
      httplib::Client c("127.0.0.1", server->port());
      c.set_read_timeout(30, 0);
      for (int i = 0; i < 25; ++i) {
        const char* path = (i + t) % 3 == 0 ? "/api/image?kind=preview&format=raw"
                           : (i + t) % 3 == 1 ? "/api/status"
                                              : "/api/lens";
        auto res = c.Get(path, auth());
        (res && res->status == 200 ? ok : failed)++;
      }
    });
  for (std::thread& t : clients) t.join();
  EXPECT_EQ(ok.load(), 200);
  EXPECT_EQ(failed.load(), 0);
  EXPECT_TRUE(alive());
}

// The focus distance becomes the camera-space depth at the clicked pixel: 1 m on the near quad
// (left half), 4 m on the far wall (right half), as the scene was built.
TEST_F(ViewServerTest, FocusAtAPixelSetsTheDepthSeenThere) {
  auto near = post("/api/focus", R"({"x": 10, "y": 24})");
  ASSERT_TRUE(near);
  ASSERT_EQ(near->status, 200) << near->body;
  EXPECT_NEAR(json::parse(near->body).at("focus_distance").get<double>(), kNear, 1e-4);
  EXPECT_NEAR(session->lens().focus_distance, kNear, 1e-4);
  auto far = post("/api/focus", R"({"x": 50, "y": 10})");
  ASSERT_TRUE(far);
  ASSERT_EQ(far->status, 200) << far->body;
  EXPECT_NEAR(json::parse(far->body).at("focus_distance").get<double>(), kFar, 1e-3);
  auto depth = client->Get("/api/depth?x=10&y=24", auth());
  ASSERT_TRUE(depth);
  EXPECT_NEAR(json::parse(depth->body).at("depth").get<double>(), kNear, 1e-4);
  EXPECT_EQ(get_status("/api/depth?x=ten&y=24", auth()), 400);
  EXPECT_EQ(get_status("/api/depth?x=10", auth()), 400);
  EXPECT_EQ(get_status("/api/depth?x=10&y=480", auth()), 400);
  auto lens = json::parse(client->Get("/api/lens", auth())->body);
  EXPECT_NEAR(lens.at("focus_distance").get<double>(), kFar, 1e-3);
  EXPECT_DOUBLE_EQ(lens.at("fstop").get<double>(), 0.5);  // only the focus changed
}

// Three clicks put a tilted plane of focus through what they see: two pixels of the near quad
// (1 m) in one column and one of the far wall (4 m). The plane holds that column's vertical
// line, so it is only swung (tilt_y), worked by hand from the pixels' slopes (yfov 0.8, 64x48):
// the points (-0.37875, y, 1) and (1.30361, -0.03523, 4) give P = 1.67539 m and
// tilt_y = asin(0.1 x 1.06435) = 6.1098 degrees for the 100 mm lens.
TEST_F(ViewServerTest, ThreeClicksPutThePlaneOfFocusThroughThem) {
  auto res = post("/api/focus_plane", R"({"points": [[10, 10], [10, 40], [50, 24]]})");
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 200) << res->body;
  const json lens = json::parse(res->body);
  EXPECT_NEAR(lens.at("focus_distance").get<double>(), 1.67539, 2e-4);
  EXPECT_NEAR(lens.at("lens_tilt")[0].get<double>(), 0.0, 1e-3);
  EXPECT_NEAR(lens.at("lens_tilt")[1].get<double>(), 6.1098, 1e-3);
  EXPECT_NEAR(session->lens().aperture.tilt_y_deg, 6.1098, 1e-3);
  // Three points of the far wall alone: an untilted plane at 4 m.
  res = post("/api/focus_plane", R"({"points": [[40, 5], [60, 20], [45, 40]]})");
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 200) << res->body;
  EXPECT_NEAR(session->lens().focus_distance, kFar, 1e-3);
  EXPECT_FALSE(session->lens().aperture.tilted() &&
               std::abs(session->lens().aperture.tilt_y_deg) > 1e-3);
  // One line, and nothing changed: three pixels on one line, too few points, outside the image.
  for (const char* body : {R"({"points": [[40, 24], [50, 24], [60, 24]]})",
                           R"({"points": [[40, 24], [50, 24]]})",
                           R"({"points": [[40, 24], [50, 24], [64, 24]]})", R"({"points": 3})"}) {
    auto bad = post("/api/focus_plane", body);
    ASSERT_TRUE(bad);
    EXPECT_EQ(bad->status, 400) << body;
    EXPECT_EQ(json::parse(bad->body).at("error").get<std::string>().find('\n'), std::string::npos);
  }
  EXPECT_NEAR(session->lens().focus_distance, kFar, 1e-3);
}

// Focused on the far wall the near quad's edge is spread over many pixels; focused on the near
// quad it is sharp. The same saved inputs, only the post-process rerun.
TEST_F(ViewServerTest, RefocusChangesTheImage) {
  const std::vector<int> far_focus = middle_row();
  ASSERT_EQ(post("/api/focus", R"({"x": 10, "y": 24})")->status, 200);
  const std::vector<int> near_focus = middle_row();
  ASSERT_FALSE(far_focus.empty());
  ASSERT_FALSE(near_focus.empty());
  EXPECT_NE(far_focus, near_focus);
  EXPECT_GE(transition_width(far_focus), 4);
  EXPECT_LE(transition_width(near_focus), 2);
  EXPECT_GT(transition_width(far_focus), 2 * transition_width(near_focus));

  // Stopping down to f/22 at the far focus narrows the blur again.
  ASSERT_EQ(post("/api/lens", R"({"focus_distance": 4.0, "fstop": 22})")->status, 200);
  EXPECT_LT(transition_width(middle_row()), transition_width(far_focus));
  // The status reports the post-process time of the last refocus.
  auto status = json::parse(client->Get("/api/status", auth())->body);
  EXPECT_GT(status.at("last_refocus_ms").get<double>(), 0.0);
  EXPECT_EQ(status.at("stage").get<std::string>(), "refined");
  EXPECT_GT(status.at("memory_bytes").get<double>(), 0.0);
}

TEST_F(ViewServerTest, ImagesComeAsPngExrOrRaw) {
  auto png = client->Get("/api/image?kind=preview&format=png", auth());
  ASSERT_TRUE(png);
  ASSERT_EQ(png->status, 200);
  EXPECT_EQ(png->get_header_value("Content-Type"), "image/png");
  EXPECT_EQ(png->body.substr(0, 4), "\x89PNG");
  auto raw = client->Get("/api/image?kind=pinhole&format=raw", auth());
  ASSERT_TRUE(raw);
  ASSERT_EQ(raw->status, 200);
  EXPECT_EQ(raw->body.size(), std::size_t(kWidth) * kHeight * 4);
  EXPECT_EQ(raw->get_header_value("X-Image-Width"), std::to_string(kWidth));
  // The EXR holds the linear values whose sRGB encoding the raw bytes are.
  auto exr = client->Get("/api/image?kind=pinhole&format=exr", auth());
  ASSERT_TRUE(exr);
  ASSERT_EQ(exr->status, 200);
  EXPECT_EQ(exr->get_header_value("Content-Type"), "image/x-exr");
  const std::string file = std::filesystem::temp_directory_path() /
                           ("dofcache_view_exr_" + std::to_string(::getpid()) + ".exr");
  std::ofstream(file, std::ios::binary) << exr->body;
  const image::Image linear = image::read_image(file);
  std::filesystem::remove(file);
  ASSERT_EQ(linear.width(), kWidth);
  ASSERT_EQ(linear.height(), kHeight);
  int off = 0;
  for (int p = 0; p < kWidth * kHeight; ++p)
    for (int c = 0; c < 3; ++c) {
      const int byte = static_cast<unsigned char>(raw->body[p * 4 + c]);
      off += std::abs(std::lround(image::linear_to_srgb(linear.data()[p * 3 + c]) * 255.0f) -
                      byte) > 0;
    }
  EXPECT_EQ(off, 0);
  // No reference in this session.
  EXPECT_EQ(get_status("/api/image?kind=reference", auth()), 503);
  EXPECT_EQ(get_status("/api/compare", auth()), 503);
  auto gltf = json::parse(client->Get("/api/lens.gltf", auth())->body);
  EXPECT_DOUBLE_EQ(gltf.at("extras").at("lens").at("fstop").get<double>(), 0.5);
}

// "Append keyframe": each press adds the camera and the lens of the moment to the file named on
// the command line, which `dofcache sequence --path` then reads; without one the route says how.
TEST_F(ViewServerTest, KeyframesAreAppendedToTheFileGivenOnly) {
  auto refused = post("/api/keyframe", "");
  ASSERT_TRUE(refused);
  EXPECT_EQ(refused->status, 409);
  EXPECT_NE(refused->body.find("--keyframes"), std::string::npos);

  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("dofcache_view_keys_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string file = (dir / "keys.json").string();
  server->stop();
  session->stop();
  start(false, file);
  auto first = post("/api/keyframe", "");
  ASSERT_TRUE(first && first->status == 200) << (first ? first->body : "no answer");
  EXPECT_EQ(json::parse(first->body)["keys"], 1);
  ASSERT_EQ(post("/api/lens", R"({"fstop": 8, "focus_distance": 3.5})")->status, 200);
  auto second = post("/api/keyframe", "");
  ASSERT_TRUE(second && second->status == 200);
  EXPECT_EQ(json::parse(second->body)["keys"], 2);

  const sequence::CameraPath path = sequence::load_keyframe_path(file, session->camera());
  EXPECT_DOUBLE_EQ(path.end_time - path.start_time, 1.0);
  EXPECT_DOUBLE_EQ(*path.at(path.start_time).fstop, 0.5);  // wide_open()
  EXPECT_DOUBLE_EQ(*path.at(path.end_time).fstop, 8.0);
  EXPECT_DOUBLE_EQ(*path.at(path.end_time).focus_distance, 3.5);
  std::filesystem::remove_all(dir);
}

TEST_F(ViewServerTest, MethodIsChosenWithoutTouchingTheLens) {
  auto res = post("/api/lens", R"({"method": "layered"})");
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 200);
  EXPECT_EQ(json::parse(res->body).at("method").get<std::string>(), "preview");
  EXPECT_EQ(session->status().method, preview::PreviewMethod::Layered);
  EXPECT_EQ(session->status().lens_version, 1u);
}

// A dolly moves the camera along its axis (depths shrink by its length, the point in focus stays
// in focus); an orbit turns it about that point. Each move renders the inputs again.
TEST_F(ViewServerTest, CameraMovesRenderTheInputsAgain) {
  auto depth_at = [&](int x, int y) {
    return json::parse(client->Get(("/api/depth?x=" + std::to_string(x) + "&y=" +
                                    std::to_string(y)).c_str(), auth())->body)["depth"];
  };
  EXPECT_NEAR(depth_at(10, 24).get<double>(), kNear, 1e-4);  // the near quad, left half
  EXPECT_NEAR(depth_at(50, 24).get<double>(), kFar, 1e-3);
  auto res = post("/api/camera", R"({"dolly": 0.5})");
  ASSERT_TRUE(res && res->status == 200) << (res ? res->body : "no answer");
  json moved = json::parse(res->body);
  EXPECT_EQ(moved["camera_version"], 1);
  EXPECT_NEAR(moved["position"][2].get<double>(), -0.5, 1e-6);
  EXPECT_NEAR(moved["lens"]["focus_distance"].get<double>(), kFar - 0.5, 1e-5);
  ASSERT_TRUE(session->wait_for_stage(InputStage::Draft, 60.0));
  EXPECT_NEAR(depth_at(50, 24).get<double>(), kFar - 0.5, 1e-3);

  // Yaw 90 degrees about the point in focus, (0, 0, -4), 3.5 m ahead: the camera goes to
  // (3.5, 0, -4), looking down -X.
  res = post("/api/camera", R"({"yaw": 90})");
  ASSERT_TRUE(res && res->status == 200);
  moved = json::parse(res->body);
  EXPECT_NEAR(moved["position"][0].get<double>(), 3.5, 1e-5);
  EXPECT_NEAR(moved["position"][2].get<double>(), -4.0, 1e-5);
  EXPECT_NEAR(moved["forward"][0].get<double>(), -1.0, 1e-6);
  EXPECT_EQ(post("/api/camera", R"({"pitch": 100})")->status, 400);
  EXPECT_EQ(post("/api/camera", R"({"yaw": "left"})")->status, 400);
  EXPECT_EQ(post("/api/camera", R"({"roll": 1})")->status, 400);
  EXPECT_EQ(session->status().camera_version, 2u);  // refused moves change nothing
}

// The slab composite changes the layered preview (the blurred edge of the near plane), not the
// lens; back to "over" gives the first image again, bit for bit.
TEST_F(ViewServerTest, CompositeIsChosenWithoutTouchingTheLens) {
  auto image = [&] { return client->Get("/api/image?kind=preview&format=raw", auth())->body; };
  ASSERT_EQ(post("/api/lens", R"({"method": "layered"})")->status, 200);
  const std::string over = image();
  auto res = post("/api/lens", R"({"composite": "slabs"})");
  ASSERT_TRUE(res && res->status == 200);
  EXPECT_EQ(json::parse(res->body).at("composite").get<std::string>(), "slabs");
  EXPECT_EQ(session->status().composite, preview::LayerComposite::Slabs);
  EXPECT_EQ(session->status().lens_version, 1u);
  const std::string slabs = image();
  ASSERT_EQ(slabs.size(), over.size());
  EXPECT_NE(slabs, over);
  ASSERT_EQ(post("/api/lens", R"({"composite": "over"})")->status, 200);
  EXPECT_EQ(image(), over);
  EXPECT_EQ(post("/api/lens", R"({"composite": "union"})")->status, 400);
  EXPECT_EQ(post("/api/lens", R"({"composite": 1})")->status, 400);
}

class ViewReferenceTest : public ViewServerTest {
 protected:
  void SetUp() override { start(/*reference=*/true); }
  int reference_spp() {
    return json::parse(client->Get("/api/status", auth())->body)
        .at("reference").at("spp").get<int>();
  }
  bool wait_for_reference(int spp) {
    for (int i = 0; i < 600 && reference_spp() < spp; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    return reference_spp() >= spp;
  }
};

// The reference refines pass by pass up to its limit, is compared with the preview, and starts
// again when the lens changes, keeping its radiance cache.
TEST_F(ViewReferenceTest, RefinesComparesAndRestartsOnALensChange) {
  ASSERT_TRUE(wait_for_reference(4));
  auto ref = client->Get("/api/image?kind=reference&format=raw", auth());
  ASSERT_TRUE(ref);
  ASSERT_EQ(ref->status, 200);
  EXPECT_EQ(ref->get_header_value("X-Reference-Spp"), "4");
  auto cmp = client->Get("/api/compare", auth());
  ASSERT_TRUE(cmp);
  ASSERT_EQ(cmp->status, 200);
  const double rel_mse = json::parse(cmp->body).at("rel_mse").get<double>();
  EXPECT_GT(rel_mse, 0.0);
  EXPECT_LT(rel_mse, 0.5);  // the preview approximates the reference
  EXPECT_TRUE(json::parse(client->Get("/api/status", auth())->body)
                  .at("reference").at("done").get<bool>());

  // A lens change restarts the reference (synchronously: the old one is dropped before the
  // request returns); the next one refines again to its limit, for the new lens. Whether the
  // restarted reference is seen before its first pass is a race with the background thread, so
  // the test compares what it converges to instead.
  ASSERT_EQ(post("/api/lens", R"({"fstop": 8})")->status, 200);
  ASSERT_TRUE(wait_for_reference(4));
  auto again = client->Get("/api/image?kind=reference&format=raw", auth());
  ASSERT_TRUE(again);
  ASSERT_EQ(again->status, 200);
  EXPECT_EQ(again->get_header_value("X-Reference-Spp"), "4");
  ASSERT_EQ(again->body.size(), ref->body.size());
  EXPECT_NE(again->body, ref->body);  // rendered through the new lens
}

// A lens change keeps the reference's radiance cache: on lit diffuse planes, the first pass
// through the new lens is served partly by samples made for the old one (the persistent cache's
// reuse rule gives them the radius the new lens allows).
TEST(ViewSessionCache, ALensChangeReusesTheReferencesCacheSamples) {
  scene::Scene s;
  s.materials.push_back(testing::diffuse_material({0.7f, 0.7f, 0.7f}));
  s.materials.push_back(testing::emissive_material({20.0f, 20.0f, 20.0f}));
  testing::add_quad_z(s, -5.0f, 0.0f, -5.0f, 5.0f, -kNear, 0, 0);
  testing::add_quad_z(s, -20.0f, 20.0f, -20.0f, 20.0f, -kFar, 0, 1);
  testing::add_light_facing_away(s, 1.0f, 2.0f, -0.5f, 1, 2);
  testing::build_emitters(s);
  s.cameras.push_back(testing::origin_camera(0.8f));
  ViewSettings settings = small_settings(/*reference=*/true);
  settings.request.shading->gather_rays = 4;
  // One pass per lens: what that pass reuses was made for the other lens.
  settings.reference_pass_spp = settings.reference_max_spp = 2;
  ViewSession session(std::move(s), wide_open(), settings);
  session.start();
  auto converged = [&] {
    for (int i = 0; i < 600; ++i) {
      const ViewStatus st = session.status();
      if (st.reference_done) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return false;
  };
  ASSERT_TRUE(converged());
  const ViewStatus first = session.status();
  EXPECT_GT(first.reference_cache_samples, 0u);
  lens::ThinLens lens = session.lens();
  lens.fstop = 2.0;
  session.set_lens(lens);
  ASSERT_TRUE(converged());
  const ViewStatus second = session.status();
  EXPECT_EQ(second.lens_version, first.lens_version + 1);
  EXPECT_GE(second.reference_cache_samples, first.reference_cache_samples);
  EXPECT_GT(second.reference_reuse_rate, 0.0);
  session.stop();
}

}  // namespace
}  // namespace dofcache::view
