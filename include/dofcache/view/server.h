#pragma once
// The HTTP server of `dofcache view`: the embedded page and a JSON API over a ViewSession
// (docs/view.md lists the routes), answered by ViewApi (api.h); this is the HTTP transport.
//
// Safe by construction:
//   * bound to 127.0.0.1 only (there is no option to bind elsewhere);
//   * every request carries the session's random token (header X-Dofcache-Token, or the query
//     parameter `token` for the page itself): 401 without one, 403 with a wrong one;
//   * no request names a file: the page is compiled in, images are made in memory, and the one
//     file a request may write is the keyframe file named on the command line;
//   * request bodies are limited to kMaxRequestBody bytes (413), URIs and headers by the HTTP
//     library (8 KiB), reads time out, and a malformed or oversized request is answered with an
//     error while the server keeps serving.
#include <memory>
#include <string>

#include "dofcache/view/api.h"

namespace dofcache::view {

class ViewSession;

constexpr std::size_t kMaxRequestBody = 16 * 1024;

// 32 hex digits from std::random_device (128 bits).
std::string random_token();

struct ServerSettings {
  int port = 0;       // 0: any free port
  std::string token;  // empty: random_token()
  // POST /api/keyframe appends the current camera and lens to this keyframe file with
  // `append_keyframe`; empty: the route answers 409.
  std::string keyframes;
  std::string scene_name;  // the keyframe file's description when it is created
  KeyframeWriter append_keyframe;
};

class ViewServer {
 public:
  // Binds 127.0.0.1:port; throws dofcache::Error if the port cannot be bound. `session` must
  // outlive the server.
  ViewServer(ViewSession& session, const ServerSettings& settings);
  ~ViewServer();  // stops
  ViewServer(const ViewServer&) = delete;
  ViewServer& operator=(const ViewServer&) = delete;

  int port() const;
  const std::string& token() const;
  // http://127.0.0.1:PORT/?token=TOKEN
  std::string url() const;

  void run();    // serves until stop() (from another thread or a signal handler's thread)
  void start();  // serves on a background thread
  void stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The resident memory of this process in bytes (Linux: /proc/self/statm; 0 elsewhere).
std::size_t resident_memory_bytes();

}  // namespace dofcache::view
