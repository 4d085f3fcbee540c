#pragma once
// The request handling of `dofcache view` (docs/view.md lists the routes): the access token, the
// routes, their parameters and JSON bodies, over a ViewSession. Kept apart from the HTTP transport
// (server.h, which parses requests, limits their size and writes the answers) so that it is tested
// and fuzzed without sockets: a request's method, path, query parameters, token header and body
// in; a status, headers and body out.
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "dofcache/lens/thin_lens.h"
#include "dofcache/scene/scene.h"

namespace dofcache::view {

class ViewSession;

// The header that carries the session's token.
constexpr const char* kTokenHeader = "X-Dofcache-Token";

struct ApiRequest {
  std::string method;  // as sent: GET, HEAD, POST, ...
  std::string path;    // URL-decoded, without the query
  std::multimap<std::string, std::string> params;  // the query's parameters, URL-decoded
  std::string token_header;                        // the X-Dofcache-Token header; "" if absent
  std::string body;
};

struct ApiResponse {
  int status = 200;
  std::string content_type;
  std::string body;
  std::vector<std::pair<std::string, std::string>> headers;  // besides the content type
};

// Appends `camera` and `lens` as a key to the keyframe file `file` (created with `description`
// if missing) and returns the number of keys in it; throws dofcache::Error. The keyframe files
// are the sequence module's (sequence::append_keyframe): the front end that starts the viewer
// passes it in, so the viewer does not depend on camera paths.
using KeyframeWriter = std::function<int(const std::string& file, const scene::Camera& camera,
                                         const lens::ThinLens& lens,
                                         const std::string& description)>;

class ViewApi {
 public:
  // `session` must outlive the API. `keyframes`: the keyframe file POST /api/keyframe appends to
  // with `append` (either empty: that route answers 409); `scene_name` its description when it is
  // created.
  ViewApi(ViewSession& session, std::string token, std::string keyframes = "",
          std::string scene_name = "", KeyframeWriter append = {});

  const std::string& token() const { return token_; }

  // The token check alone (the transport runs it before it reads a body): 401 without a token
  // (neither the header nor the query parameter `token`), 403 with a wrong one, nullopt if the
  // request may go on.
  std::optional<ApiResponse> check_token(const ApiRequest& request) const;
  // Answers a request whose token was checked. Never throws for anything a request holds: bad
  // input is a 400 with {"error": "..."} (one line), an unknown route a 404, an image not made
  // yet a 503; a 500 means a bug.
  ApiResponse route(const ApiRequest& request);
  // check_token, then route.
  ApiResponse handle(const ApiRequest& request);

  // The JSON error answer {"error": message} (text not valid UTF-8 is replaced, not refused).
  static ApiResponse error(int status, const std::string& message);

 private:
  ApiResponse route_or_throw(const ApiRequest& request);
  ApiResponse image(const ApiRequest& request);

  ViewSession& session_;
  std::string token_;
  std::string keyframes_, scene_name_;
  KeyframeWriter append_keyframe_;
};

}  // namespace dofcache::view
