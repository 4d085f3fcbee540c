// The request handling of `dofcache view` (view::ViewApi: the token, the routes, query parameters,
// JSON bodies) over two small in-memory sessions, without sockets. The input is a request:
//
//   METHOD TARGET\n      e.g. "POST /api/lens" or "GET /api/depth?x=3&y=4&token=..."
//   TOKEN-HEADER\n       the X-Dofcache-Token header's value; an empty line: no header
//   BODY                 the rest
//
// TARGET is split and URL-decoded by the HTTP library's own functions, as its server does. Each
// request goes to both sessions, each with its own token: one has its inputs (rendered once, at
// 16x16), one was never started (nothing to show yet). Every answer must be one the API documents
// (200, 400, 401, 403, 404, 503; a 500 means an exception other than dofcache::Error escaped),
// JSON answers must parse, error messages must be one line, raw images the image's size.
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>

#include <httplib.h>
#include <nlohmann/json.hpp>

#include "dofcache/view/api.h"
#include "dofcache/view/session.h"
#include "render/test_scenes.h"

namespace {

using namespace dofcache;

constexpr int kWidth = 16, kHeight = 16;  // the smallest a session allows
// The tokens are in view.dict and the seeds.
constexpr const char* kReadyToken = "0123456789abcdef0123456789abcdef";
constexpr const char* kEmptyToken = "fedcba9876543210fedcba9876543210";

// Camera at the origin looking down -Z: an emissive quad at 1 m over the left half, a dimmer
// wall at 4 m behind (so depths, focus and refocus all have something to work on), and the
// top-right corner sees nothing (focus there is refused).
scene::Scene two_planes() {
  scene::Scene s;
  s.materials.push_back(testing::emissive_material({0.8f, 0.8f, 0.8f}));
  s.materials.push_back(testing::emissive_material({0.2f, 0.2f, 0.2f}));
  testing::add_quad_z(s, -5.0f, 0.0f, -5.0f, 5.0f, -1.0f, 0, 0);
  testing::add_quad_z(s, -20.0f, 1.0f, -20.0f, 1.0f, -4.0f, 1, 1);
  testing::build_emitters(s);
  s.cameras.push_back(testing::origin_camera(0.8f));
  return s;
}

view::ViewSettings settings() {
  view::ViewSettings s;
  s.request.width = kWidth;
  s.request.height = kHeight;
  s.request.threads = 1;
  s.input_spp = 1;
  s.reference = false;  // no background work: every answer depends on the request alone
  s.request.shading = render::ShadingSettings{};
  s.request.shading->gather_rays = 0;
  s.request.shading->light_samples = 1;
  return s;
}

const render::LensOverrides kLens{0.05, 2.0, 4.0, {}, {}};

struct Sessions {
  Sessions()
      : ready(two_planes(), kLens, settings()),
        empty(two_planes(), kLens, settings()),
        ready_api(ready, kReadyToken),
        empty_api(empty, kEmptyToken) {
    ready.start();
    if (!ready.wait_for_stage(view::InputStage::Refined, 600.0)) {
      std::fprintf(stderr, "fuzz: the view session made no inputs\n");
      std::abort();
    }
    ready.stop();  // the worker has finished (no reference): nothing changes in the background
    initial_lens = ready.lens();
    initial_camera = ready.camera();
  }
  view::ViewSession ready, empty;
  view::ViewApi ready_api, empty_api;
  lens::ThinLens initial_lens;
  scene::Camera initial_camera;
};

[[noreturn]] void finding(const char* what, const view::ApiRequest& req,
                          const view::ApiResponse& res) {
  std::fprintf(stderr, "fuzz: %s: %s %s -> %d [%s]\n", what, req.method.c_str(),
               req.path.c_str(), res.status, res.body.substr(0, 300).c_str());
  std::abort();
}

void check(const view::ApiRequest& req, const view::ApiResponse& res) {
  // Replaying an input with DOFCACHE_FUZZ_VERBOSE set shows the answers.
  static const bool verbose = std::getenv("DOFCACHE_FUZZ_VERBOSE") != nullptr;
  if (verbose)
    std::fprintf(stderr, "%s %s -> %d %s [%s]\n", req.method.c_str(), req.path.c_str(),
                 res.status, res.content_type.c_str(),
                 res.content_type == "application/json" ? res.body.substr(0, 200).c_str() : "");
  switch (res.status) {
    case 200: case 400: case 401: case 403: case 404: case 409: case 503: break;
    default: finding("unexpected status", req, res);
  }
  if (res.content_type == "application/json") {
    const nlohmann::json j = nlohmann::json::parse(res.body, nullptr, false);
    if (j.is_discarded() || !j.is_object()) finding("answer is not a JSON object", req, res);
    if (res.status != 200) {
      auto e = j.find("error");
      if (e == j.end() || !e->is_string() || e->get<std::string>().empty() ||
          e->get<std::string>().find_first_of("\r\n") != std::string::npos)
        finding("error answer without a one-line message", req, res);
    }
  } else if (res.status != 200) {
    finding("error answer that is not JSON", req, res);
  } else if (res.content_type == "application/octet-stream" &&
             res.body.size() != std::size_t(kWidth) * kHeight * 4) {
    finding("raw image of the wrong size", req, res);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static Sessions* sessions = new Sessions();  // never destroyed: a session joins no thread then
  const std::string input(reinterpret_cast<const char*>(data), size);

  view::ApiRequest req;
  const std::size_t line1 = input.find('\n');
  const std::string request_line = input.substr(0, line1);
  std::string rest = line1 == std::string::npos ? "" : input.substr(line1 + 1);
  const std::size_t line2 = rest.find('\n');
  req.token_header = rest.substr(0, line2);
  req.body = line2 == std::string::npos ? "" : rest.substr(line2 + 1);
  const std::size_t space = request_line.find(' ');
  req.method = request_line.substr(0, space);
  const std::string target = space == std::string::npos ? "" : request_line.substr(space + 1);
  const std::size_t query = target.find('?');
  req.path = httplib::detail::decode_url(target.substr(0, query), false);
  if (query != std::string::npos)
    httplib::detail::parse_query_text(target.substr(query + 1), req.params);

  // Each input starts from the same camera, lens, method and composite.
  sessions->ready.set_camera(sessions->initial_camera);
  sessions->ready.set_real_lens("");
  sessions->ready.set_lens(sessions->initial_lens);
  sessions->ready.set_method(preview::PreviewMethod::LayeredOcclusion);
  sessions->ready.set_composite(preview::LayerComposite::Over);
  check(req, sessions->ready_api.handle(req));
  check(req, sessions->empty_api.handle(req));
  return 0;
}
