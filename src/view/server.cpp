#include "dofcache/view/server.h"

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <exception>
#include <fstream>
#include <initializer_list>
#include <random>
#include <thread>
#include <utility>

#include <glm/geometric.hpp>
#include <httplib.h>
#include <nlohmann/json.hpp>
#include <tbb/parallel_for.h>

#include "dofcache/core/error.h"
#include "dofcache/image/image_io.h"
#include "dofcache/sequence/camera_path.h"
#include "dofcache/view/page.h"
#include "dofcache/view/session.h"

namespace dofcache::view {
namespace {

using json = nlohmann::json;
constexpr const char* kTokenHeader = "X-Dofcache-Token";

// Compares in time independent of where the strings differ.
bool same_token(const std::string& a, const std::string& b) {
  if (a.size() != b.size()) return false;
  unsigned char diff = 0;
  for (std::size_t i = 0; i < a.size(); ++i) diff |= static_cast<unsigned char>(a[i] ^ b[i]);
  return diff == 0;
}

void send_json(httplib::Response& res, const json& body, int status = 200) {
  res.status = status;
  res.set_content(body.dump(), "application/json");
}

void send_error(httplib::Response& res, int status, const std::string& message) {
  send_json(res, {{"error", message}}, status);
}

json lens_json(const lens::ThinLens& lens) {
  return {{"focal_length", lens.focal_length},
          {"fstop", lens.fstop},
          {"focus_distance", lens.focus_distance}};
}

// The lens and the preview method, as GET and POST /api/lens answer.
const char* composite_name(preview::LayerComposite c) {
  return c == preview::LayerComposite::Slabs ? "slabs" : "over";
}

json lens_and_method_json(const ViewStatus& s) {
  json j = lens_json(s.lens);
  j["method"] = preview::preview_method_name(s.method);
  j["composite"] = composite_name(s.composite);
  return j;
}

// Where the camera is and looks, with the lens (which a dolly refocuses).
json camera_json(const scene::Camera& c, const ViewStatus& s) {
  const glm::vec3 p(c.camera_to_world[3]), f = -glm::normalize(glm::vec3(c.camera_to_world[2]));
  return {{"position", {p.x, p.y, p.z}},
          {"forward", {f.x, f.y, f.z}},
          {"camera_version", s.camera_version},
          {"lens", lens_json(s.lens)}};
}

json number_or_null(double v) { return v < 0 ? json(nullptr) : json(v); }

json status_json(const ViewStatus& s) {
  return {{"width", s.width},
          {"height", s.height},
          {"lens", lens_json(s.lens)},
          {"method", preview::preview_method_name(s.method)},
          {"composite", composite_name(s.composite)},
          {"lens_version", s.lens_version},
          {"camera_version", s.camera_version},
          {"stage", input_stage_name(s.stage)},
          {"inputs_version", s.inputs_version},
          {"first_preview_ms", number_or_null(s.first_preview_ms)},
          {"last_refocus_ms", number_or_null(s.last_refocus_ms)},
          {"refocus_warning", s.refocus_warning},
          {"reference",
           {{"spp", s.reference_spp},
            {"version", s.reference_version},
            {"seconds", s.reference_seconds},
            {"done", s.reference_done}}},
          {"memory_bytes", resident_memory_bytes()},
          {"error", s.error}};
}

// The request body as a JSON object; throws dofcache::Error (400) otherwise.
json body_object(const httplib::Request& req) {
  json body = json::parse(req.body, nullptr, /*allow_exceptions=*/false);
  if (body.is_discarded() || !body.is_object())
    throw Error("the request body must be a JSON object");
  return body;
}

// Refuses keys other than `known`, so a misspelt one is not silently ignored.
void check_keys(const json& body, std::initializer_list<const char*> known) {
  for (auto it = body.begin(); it != body.end(); ++it) {
    bool found = false;
    for (const char* k : known) found = found || it.key() == k;
    if (!found) throw Error("unknown key '" + it.key().substr(0, 64) + "'");
  }
}

// body[key] as a number if present; throws dofcache::Error if it is not one.
std::optional<double> optional_number(const json& body, const char* key) {
  auto it = body.find(key);
  if (it == body.end()) return std::nullopt;
  if (!it->is_number()) throw Error(std::string("'") + key + "' must be a number");
  return it->get<double>();
}

struct Pixel {
  int x, y;
};

// A pixel given as two numbers; throws dofcache::Error (400) if either is missing or absurd (the
// session checks it against the image).
Pixel pixel(std::optional<double> x, std::optional<double> y) {
  if (!x || !y) throw Error("a pixel needs both x and y");
  if (!(*x >= 0 && *x < 1e6 && *y >= 0 && *y < 1e6))
    throw Error("the pixel must have non-negative coordinates inside the image");
  return {static_cast<int>(*x), static_cast<int>(*y)};
}

// 8-bit sRGB RGBA, row-major from the top: what a canvas's ImageData takes as is.
std::string rgba8(const image::Image& color) {
  std::string bytes(color.pixel_count() * 4, '\xff');
  const float* src = color.data().data();
  const int c = color.channels();
  tbb::parallel_for(std::size_t{0}, color.pixel_count(), std::size_t{4096},
                    [&](std::size_t p0) {
                      const std::size_t p1 = std::min(p0 + 4096, color.pixel_count());
                      for (std::size_t p = p0; p < p1; ++p)
                        for (int k = 0; k < 3; ++k) {
                          const float v = image::linear_to_srgb(src[p * c + std::min(k, c - 1)]);
                          bytes[p * 4 + k] = static_cast<char>(std::lround(v * 255.0f));
                        }
                    });
  return bytes;
}

}  // namespace

std::string random_token() {
  std::random_device device;
  std::string token;
  char hex[9];
  for (int i = 0; i < 4; ++i) {
    std::snprintf(hex, sizeof hex, "%08x", static_cast<unsigned>(device()));
    token += hex;
  }
  return token;
}

std::size_t resident_memory_bytes() {
  std::ifstream statm("/proc/self/statm");
  std::size_t pages_total = 0, pages_resident = 0;
  if (!(statm >> pages_total >> pages_resident)) return 0;
  return pages_resident * static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
}

struct ViewServer::Impl {
  Impl(ViewSession& s, const ServerSettings& settings)
      : session(s),
        settings(settings),
        token(settings.token.empty() ? random_token() : settings.token) {}

  void configure();
  void add_routes();
  httplib::Server::HandlerResponse check_token(const httplib::Request& req,
                                               httplib::Response& res) const;
  void send_image(const httplib::Request& req, httplib::Response& res);

  ViewSession& session;
  ServerSettings settings;
  std::string token;
  httplib::Server server;
  int port = 0;
  std::thread thread;
};

httplib::Server::HandlerResponse ViewServer::Impl::check_token(const httplib::Request& req,
                                                               httplib::Response& res) const {
  std::string given = req.get_header_value(kTokenHeader);
  if (given.empty() && req.has_param("token")) given = req.get_param_value("token");
  if (given.empty()) {
    send_error(res, 401, "this server needs its access token (printed when it started)");
    return httplib::Server::HandlerResponse::Handled;
  }
  if (!same_token(given, token)) {
    send_error(res, 403, "wrong access token");
    return httplib::Server::HandlerResponse::Handled;
  }
  return httplib::Server::HandlerResponse::Unhandled;
}

void ViewServer::Impl::configure() {
  // The library's default also sets SO_REUSEPORT, which lets a second process bind the same port
  // and take some of the connections (and with them the token): SO_REUSEADDR only, so a port in
  // use is an error.
  server.set_socket_options([](socket_t sock) {
    int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
  });
  server.set_payload_max_length(kMaxRequestBody);
  server.set_read_timeout(5, 0);
  server.set_write_timeout(5, 0);
  server.set_keep_alive_max_count(100);
  server.set_keep_alive_timeout(5);
  // The token travels in the page's URL: never to another site (Referrer-Policy), and nothing is
  // loaded from elsewhere (the page is self-contained).
  server.set_default_headers(
      {{"Cache-Control", "no-store"},
       {"X-Content-Type-Options", "nosniff"},
       {"Referrer-Policy", "no-referrer"},
       {"X-Frame-Options", "DENY"},
       {"Content-Security-Policy",
        "default-src 'none'; script-src 'unsafe-inline'; style-src 'unsafe-inline'; "
        "img-src 'self' blob: data:; connect-src 'self'; frame-ancestors 'none'"}});
  server.set_pre_routing_handler(
      [this](const httplib::Request& req, httplib::Response& res) { return check_token(req, res); });
  server.set_exception_handler(
      [](const httplib::Request&, httplib::Response& res, std::exception_ptr ep) {
        try {
          std::rethrow_exception(ep);
        } catch (const Error& e) {
          send_error(res, 400, e.what());
        } catch (const std::exception& e) {
          send_error(res, 500, e.what());
        } catch (...) {
          send_error(res, 500, "internal error");
        }
      });
  server.set_error_handler([](const httplib::Request&, httplib::Response& res) {
    if (res.body.empty()) {
      const char* message = res.status == 404   ? "no such route"
                            : res.status == 413 ? "request too large"
                                                : "bad request";
      send_error(res, res.status, message);
    }
  });
}

void ViewServer::Impl::send_image(const httplib::Request& req, httplib::Response& res) {
  const std::string kind = req.has_param("kind") ? req.get_param_value("kind") : "preview";
  const std::string format = req.has_param("format") ? req.get_param_value("format") : "png";
  if (format != "png" && format != "raw" && format != "exr")
    throw Error("format must be png, exr or raw, not '" + format + "'");
  std::optional<ViewImage> image;
  if (kind == "preview")
    image = session.preview();
  else if (kind == "reference")
    image = session.reference();
  else if (kind == "pinhole")
    image = session.pinhole();
  else
    throw Error("kind must be preview, reference or pinhole, not '" + kind + "'");
  if (!image) return send_error(res, 503, "no " + kind + " image yet");
  res.set_header("X-Image-Width", std::to_string(image->color.width()));
  res.set_header("X-Image-Height", std::to_string(image->color.height()));
  res.set_header("X-Refocus-Ms", std::to_string(image->refocus_ms));
  res.set_header("X-Reference-Spp", std::to_string(image->reference_spp));
  res.set_header("X-Lens-Version", std::to_string(image->lens_version));
  res.set_header("X-Inputs-Version", std::to_string(image->inputs_version));
  if (format == "raw") return res.set_content(rgba8(image->color), "application/octet-stream");
  const bool exr = format == "exr";  // linear float, for compositing; png is 8-bit sRGB
  const std::vector<unsigned char> bytes =
      exr ? image::encode_exr(image->color) : image::encode_png(image->color);
  res.set_content(std::string(bytes.begin(), bytes.end()), exr ? "image/x-exr" : "image/png");
}

void ViewServer::Impl::add_routes() {
  server.Get("/", [](const httplib::Request&, httplib::Response& res) {
    res.set_content(page_html(), "text/html; charset=utf-8");
  });
  server.Get("/api/status", [this](const httplib::Request&, httplib::Response& res) {
    send_json(res, status_json(session.status()));
  });
  server.Get("/api/lens", [this](const httplib::Request&, httplib::Response& res) {
    send_json(res, lens_and_method_json(session.status()));
  });
  // Any of focal_length, fstop, focus_distance (metres, f-number), method and composite.
  server.Post("/api/lens", [this](const httplib::Request& req, httplib::Response& res) {
    const json body = body_object(req);
    check_keys(body, {"focal_length", "fstop", "focus_distance", "method", "composite"});
    lens::ThinLens lens = session.lens();
    if (auto v = optional_number(body, "focal_length")) lens.focal_length = *v;
    if (auto v = optional_number(body, "fstop")) lens.fstop = *v;
    if (auto v = optional_number(body, "focus_distance")) lens.focus_distance = *v;
    std::optional<preview::PreviewMethod> method;
    if (auto it = body.find("method"); it != body.end()) {
      if (!it->is_string()) throw Error("'method' must be a string");
      method = preview::parse_preview_method(it->get<std::string>());
    }
    std::optional<preview::LayerComposite> composite;
    if (auto it = body.find("composite"); it != body.end()) {
      const std::string c = it->is_string() ? it->get<std::string>() : "";
      if (c != "over" && c != "slabs") throw Error("'composite' must be \"over\" or \"slabs\"");
      composite = c == "slabs" ? preview::LayerComposite::Slabs : preview::LayerComposite::Over;
    }
    session.set_lens(lens);  // validates first, so a bad lens changes nothing
    if (method) session.set_method(*method);
    if (composite) session.set_composite(*composite);
    send_json(res, lens_and_method_json(session.status()));
  });
  // {x, y}: pixel of the image; focuses at the depth seen there.
  server.Post("/api/focus", [this](const httplib::Request& req, httplib::Response& res) {
    const json body = body_object(req);
    check_keys(body, {"x", "y"});
    const Pixel p = pixel(optional_number(body, "x"), optional_number(body, "y"));
    send_json(res, lens_json(session.focus_at(p.x, p.y)));
  });
  // ?x=X&y=Y: the depth seen there (null: nothing).
  server.Get("/api/depth", [this](const httplib::Request& req, httplib::Response& res) {
    auto param = [&](const char* key) -> std::optional<double> {
      if (!req.has_param(key)) return std::nullopt;
      const std::string v = req.get_param_value(key);
      char* end = nullptr;
      const double d = std::strtod(v.c_str(), &end);
      if (v.empty() || *end != '\0') throw Error(std::string("'") + key + "' must be a number");
      return d;
    };
    const Pixel p = pixel(param("x"), param("y"));
    const double d = session.depth_at(p.x, p.y);
    send_json(res, {{"depth", std::isfinite(d) ? json(d) : json(nullptr)}});
  });
  server.Get("/api/image", [this](const httplib::Request& req, httplib::Response& res) {
    send_image(req, res);
  });
  server.Get("/api/compare", [this](const httplib::Request&, httplib::Response& res) {
    const std::optional<image::ErrorMetrics> m = session.compare();
    if (!m) return send_error(res, 503, "no reference for the current lens yet");
    send_json(res, {{"rel_mse", m->rel_mse}, {"psnr", m->psnr}, {"ssim", m->ssim},
                    {"reference_spp", session.status().reference_spp}});
  });
  // {yaw, pitch (degrees), dolly (metres)}, each optional: moves the camera (ViewSession::
  // move_camera); the inputs are rendered again and the reference restarts.
  server.Post("/api/camera", [this](const httplib::Request& req, httplib::Response& res) {
    const json body = body_object(req);
    check_keys(body, {"yaw", "pitch", "dolly"});
    constexpr double kRadians = M_PI / 180.0;
    const scene::Camera c = session.move_camera(optional_number(body, "yaw").value_or(0) * kRadians,
                                                optional_number(body, "pitch").value_or(0) * kRadians,
                                                optional_number(body, "dolly").value_or(0));
    send_json(res, camera_json(c, session.status()));
  });
  // Appends the camera and the lens as a key of the keyframe file given with --keyframes, for
  // `dofcache sequence --path`.
  server.Post("/api/keyframe", [this](const httplib::Request&, httplib::Response& res) {
    if (settings.keyframes.empty())
      return send_error(res, 409, "no keyframe file: start dofcache view with --keyframes FILE");
    const lens::ThinLens lens = session.lens();
    const int keys = sequence::append_keyframe(settings.keyframes, session.camera(), lens,
                                               "keys from dofcache view of " + settings.scene_name);
    send_json(res, {{"keys", keys}, {"file", settings.keyframes}, {"lens", lens_json(lens)}});
  });
  // The lens as a glTF camera node's extras (docs/scenes.md), ready to paste.
  server.Get("/api/lens.gltf", [this](const httplib::Request&, httplib::Response& res) {
    send_json(res, {{"extras", {{"lens", lens_json(session.lens())}}}});
  });
}

ViewServer::ViewServer(ViewSession& session, const ServerSettings& settings)
    : impl_(std::make_unique<Impl>(session, settings)) {
  if (settings.port < 0 || settings.port > 65535)
    throw Error("view: port must be in [0, 65535] (0: any free port)");
  impl_->configure();
  impl_->add_routes();
  if (settings.port == 0) {
    impl_->port = impl_->server.bind_to_any_port("127.0.0.1");
    if (impl_->port < 0) throw Error("view: cannot bind any port on 127.0.0.1");
  } else {
    if (!impl_->server.bind_to_port("127.0.0.1", settings.port))
      throw Error("view: cannot bind 127.0.0.1:" + std::to_string(settings.port) +
                  " (in use? --port 0 picks a free one)");
    impl_->port = settings.port;
  }
}

ViewServer::~ViewServer() { stop(); }

int ViewServer::port() const { return impl_->port; }
const std::string& ViewServer::token() const { return impl_->token; }
std::string ViewServer::url() const {
  return "http://127.0.0.1:" + std::to_string(impl_->port) + "/?token=" + impl_->token;
}

void ViewServer::run() { impl_->server.listen_after_bind(); }

void ViewServer::start() {
  if (impl_->thread.joinable()) return;
  impl_->thread = std::thread([this] { impl_->server.listen_after_bind(); });
  // stop() before the listening loop has started would not end it: wait for it (briefly).
  for (int i = 0; i < 500 && !impl_->server.is_running(); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
}

void ViewServer::stop() {
  impl_->server.stop();
  if (impl_->thread.joinable()) impl_->thread.join();
}

}  // namespace dofcache::view
