#include "dofcache/view/server.h"

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <exception>
#include <fstream>
#include <optional>
#include <random>
#include <thread>

#include <httplib.h>

#include "dofcache/core/error.h"
#include "dofcache/view/api.h"

namespace dofcache::view {
namespace {

// The request as the API takes it. The body is read by the HTTP library after the pre-routing
// handler (the token check) has run, so that check sees it empty.
ApiRequest api_request(const httplib::Request& req) {
  ApiRequest r;
  r.method = req.method;
  r.path = req.path;
  r.params = req.params;
  r.token_header = req.get_header_value(kTokenHeader);
  r.body = req.body;
  return r;
}

void send(const ApiResponse& answer, httplib::Response& res) {
  res.status = answer.status;
  for (const auto& [name, value] : answer.headers) res.set_header(name.c_str(), value);
  res.set_content(answer.body, answer.content_type.c_str());
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
      : api(s, settings.token.empty() ? random_token() : settings.token, settings.keyframes,
            settings.scene_name, settings.append_keyframe) {}

  void configure();
  void add_routes();

  ViewApi api;
  httplib::Server server;
  int port = 0;
  std::thread thread;
};

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
  // Before the body is read: a request without the token gets no further.
  server.set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
    if (std::optional<ApiResponse> refused = api.check_token(api_request(req))) {
      send(*refused, res);
      return httplib::Server::HandlerResponse::Handled;
    }
    return httplib::Server::HandlerResponse::Unhandled;
  });
  // The API answers its own errors; this is for what is thrown around it (memory).
  server.set_exception_handler(
      [](const httplib::Request&, httplib::Response& res, std::exception_ptr ep) {
        try {
          std::rethrow_exception(ep);
        } catch (const std::exception& e) {
          send(ViewApi::error(500, e.what()), res);
        } catch (...) {
          send(ViewApi::error(500, "internal error"), res);
        }
      });
  // The HTTP library's own refusals (a malformed request line, a body over the limit) and the
  // methods without routes (PUT, DELETE, ...).
  server.set_error_handler([](const httplib::Request&, httplib::Response& res) {
    if (res.body.empty()) {
      const char* message = res.status == 404   ? "no such route"
                            : res.status == 413 ? "request too large"
                                                : "bad request";
      send(ViewApi::error(res.status, message), res);
    }
  });
}

// Every GET (and HEAD) and POST goes to the API, which routes them (docs/view.md).
void ViewServer::Impl::add_routes() {
  auto handler = [this](const httplib::Request& req, httplib::Response& res) {
    send(api.route(api_request(req)), res);
  };
  // [\s\S]: any path, line breaks (decoded %0A) included.
  server.Get(R"([\s\S]*)", handler);
  server.Post(R"([\s\S]*)", handler);
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
const std::string& ViewServer::token() const { return impl_->api.token(); }
std::string ViewServer::url() const {
  return "http://127.0.0.1:" + std::to_string(impl_->port) + "/?token=" + impl_->api.token();
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
