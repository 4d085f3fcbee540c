#include "dofcache/view/api.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <tuple>
#include <exception>
#include <initializer_list>

#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>
#include <tbb/parallel_for.h>

#include "dofcache/core/error.h"
#include "dofcache/lens/lens_json.h"
#include "dofcache/lens/shipped_lenses.h"
#include "dofcache/image/image_io.h"
#include "dofcache/view/page.h"
#include "dofcache/view/server.h"
#include "dofcache/view/session.h"

namespace dofcache::view {
namespace {

using json = nlohmann::json;

// Compares in time independent of where the strings differ.
bool same_token(const std::string& a, const std::string& b) {
  if (a.size() != b.size()) return false;
  unsigned char diff = 0;
  for (std::size_t i = 0; i < a.size(); ++i) diff |= static_cast<unsigned char>(a[i] ^ b[i]);
  return diff == 0;
}

ApiResponse json_response(const json& body, int status = 200) {
  ApiResponse res;
  res.status = status;
  res.content_type = "application/json";
  // Error messages quote the request's text, which need not be UTF-8 (a query parameter, a key
  // cut at 64 bytes inside a character): replaced, where the default would throw.
  res.body = body.dump(-1, ' ', false, json::error_handler_t::replace);
  return res;
}

using lens::lens_json;
using preview::layer_composite_name;

// The lens, the preview method and composite, as GET and POST /api/lens answer.
json lens_and_method_json(const ViewStatus& s) {
  json j = lens_json(s.lens);
  j["lens_file"] = s.real_lens ? json(s.real_lens.source) : json(nullptr);
  j["method"] = preview::preview_method_name(s.method);
  j["composite"] = layer_composite_name(s.composite);
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

// The menus' entries, {name, label}, from the preview module's name tables: the page spells none.
json choices_json() {
  json methods = json::array(), composites = json::array();
  for (const std::string& n : preview::preview_method_names())
    methods.push_back(
        {{"name", n}, {"label", preview::preview_method_label(preview::parse_preview_method(n))}});
  for (const std::string& n : preview::layer_composite_names())
    composites.push_back(
        {{"name", n}, {"label", preview::layer_composite_label(preview::parse_layer_composite(n))}});
  json lenses = json::array();
  for (const lens::ShippedLens& l : lens::shipped_lenses()) lenses.push_back(l.name);
  return {{"methods", methods}, {"composites", composites}, {"lenses", lenses}};
}

json status_json(const ViewStatus& s) {
  return {{"width", s.width},
          {"choices", choices_json()},
          {"height", s.height},
          {"lens", lens_json(s.lens)},
          {"real_lens", s.real_lens ? lens::real_lens_json(s.real_lens) : json(nullptr)},
          {"method", preview::preview_method_name(s.method)},
          {"composite", layer_composite_name(s.composite)},
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
            {"done", s.reference_done},
            {"cache_samples", s.reference_cache_samples},
            {"reuse_rate", s.reference_reuse_rate}}},
          {"memory_bytes", resident_memory_bytes()},
          {"error", s.error}};
}

// The first value of query parameter `key`, if present.
std::optional<std::string> param(const ApiRequest& req, const char* key) {
  // The first of equal keys, as the HTTP library's get_param_value (find may return any).
  auto range = req.params.equal_range(key);
  if (range.first == range.second) return std::nullopt;
  return range.first->second;
}

// The request body as a JSON object; throws dofcache::Error (400) otherwise.
json body_object(const ApiRequest& req) {
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

// Query parameter `key` as a number if present; throws dofcache::Error if it is not one.
std::optional<double> number_param(const ApiRequest& req, const char* key) {
  const std::optional<std::string> v = param(req, key);
  if (!v) return std::nullopt;
  char* end = nullptr;
  const double d = std::strtod(v->c_str(), &end);
  if (v->empty() || *end != '\0') throw Error(std::string("'") + key + "' must be a number");
  return d;
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

ViewApi::ViewApi(ViewSession& session, std::string token, std::string keyframes,
                 std::string scene_name, KeyframeWriter append)
    : session_(session),
      token_(std::move(token)),
      keyframes_(std::move(keyframes)),
      scene_name_(std::move(scene_name)),
      append_keyframe_(std::move(append)) {}

ApiResponse ViewApi::error(int status, const std::string& message) {
  return json_response({{"error", one_line(message)}}, status);
}

std::optional<ApiResponse> ViewApi::check_token(const ApiRequest& req) const {
  std::string given = req.token_header;
  if (given.empty()) given = param(req, "token").value_or("");
  if (given.empty())
    return error(401, "this server needs its access token (printed when it started)");
  if (!same_token(given, token_)) return error(403, "wrong access token");
  return std::nullopt;
}

ApiResponse ViewApi::handle(const ApiRequest& req) {
  if (std::optional<ApiResponse> refused = check_token(req)) return *refused;
  return route(req);
}

ApiResponse ViewApi::route(const ApiRequest& req) {
  try {
    return route_or_throw(req);
  } catch (const Error& e) {
    return error(400, e.what());
  } catch (const std::exception& e) {
    return error(500, e.what());
  } catch (...) {
    return error(500, "internal error");
  }
}

ApiResponse ViewApi::image(const ApiRequest& req) {
  const std::string kind = param(req, "kind").value_or("preview");
  const std::string format = param(req, "format").value_or("png");
  if (format != "png" && format != "raw" && format != "exr")
    throw Error("format must be png, exr or raw, not '" + format + "'");
  std::optional<ViewImage> image;
  if (kind == "preview")
    image = session_.preview();
  else if (kind == "reference")
    image = session_.reference();
  else if (kind == "pinhole")
    image = session_.pinhole();
  else
    throw Error("kind must be preview, reference or pinhole, not '" + kind + "'");
  if (!image) return error(503, "no " + kind + " image yet");
  ApiResponse res;
  res.headers = {{"X-Image-Width", std::to_string(image->color.width())},
                 {"X-Image-Height", std::to_string(image->color.height())},
                 {"X-Refocus-Ms", std::to_string(image->refocus_ms)},
                 {"X-Reference-Spp", std::to_string(image->reference_spp)},
                 {"X-Lens-Version", std::to_string(image->lens_version)},
                 {"X-Inputs-Version", std::to_string(image->inputs_version)}};
  if (format == "raw") {
    res.content_type = "application/octet-stream";
    res.body = rgba8(image->color);
  } else {  // exr: linear float, for compositing; png: 8-bit sRGB
    const bool exr = format == "exr";
    const std::vector<unsigned char> bytes =
        exr ? image::encode_exr(image->color) : image::encode_png(image->color);
    res.content_type = exr ? "image/x-exr" : "image/png";
    res.body.assign(bytes.begin(), bytes.end());
  }
  return res;
}

ApiResponse ViewApi::route_or_throw(const ApiRequest& req) {
  // HEAD is answered as GET (the transport drops the body); methods without routes, like paths
  // without one, are 404.
  const bool get = req.method == "GET" || req.method == "HEAD";
  const bool post = req.method == "POST";
  const std::string& path = req.path;

  if (get && path == "/") {
    ApiResponse res;
    res.content_type = "text/html; charset=utf-8";
    res.body = page_html();
    return res;
  }
  if (get && path == "/api/status") return json_response(status_json(session_.status()));
  if (get && path == "/api/lens") return json_response(lens_and_method_json(session_.status()));
  // Any of focal_length, fstop, focus_distance (metres, f-number), the lens's character
  // (aperture_blades, aperture_rotation, aperture_roundness, anamorphic_ratio, vignetting_stop,
  // axial_ca, lateral_ca, aperture_profile, aperture_profile_strength, lens_tilt, lens_shift,
  // aperture_image: lens/aperture.h; a null vignetting_stop or aperture_image removes it),
  // method and composite; lens_file (a shipped lens's name or a prescription file; null: the
  // thin lens) is applied first, the other values then to the lens it mounts.
  if (post && path == "/api/lens") {
    const json body = body_object(req);
    check_keys(body, {"focal_length", "fstop", "focus_distance", "aperture_blades",
                      "aperture_rotation", "aperture_roundness", "anamorphic_ratio",
                      "vignetting_stop", "axial_ca", "lateral_ca", "aperture_profile",
                      "aperture_profile_strength", "lens_tilt", "lens_shift", "aperture_image",
                      "method", "composite", "lens_file"});
    if (auto it = body.find("lens_file"); it != body.end()) {
      if (!it->is_null() && !it->is_string())
        throw Error("'lens_file' must be a shipped lens's name, a lens file or null");
      session_.set_real_lens(it->is_null() ? std::string() : it->get<std::string>());
    }
    lens::ThinLens lens = session_.lens();
    if (auto v = optional_number(body, "focal_length")) lens.focal_length = *v;
    if (auto v = optional_number(body, "fstop")) lens.fstop = *v;
    if (auto v = optional_number(body, "focus_distance")) lens.focus_distance = *v;
    lens::ApertureShape& a = lens.aperture;
    if (auto v = optional_number(body, "aperture_blades")) {
      const std::optional<int> blades = lens::blade_count(*v);
      if (!blades) throw Error("'aperture_blades' must be a whole number");
      a.blades = *blades;
    }
    if (auto v = optional_number(body, "aperture_rotation")) a.rotation_deg = *v;
    if (auto v = optional_number(body, "aperture_roundness")) a.roundness = *v;
    if (auto v = optional_number(body, "anamorphic_ratio")) a.anamorphic_ratio = *v;
    if (auto it = body.find("vignetting_stop"); it != body.end()) {
      const std::optional<lens::VignettingStop> stop =
          it->is_null() ? lens::VignettingStop{} : lens::vignetting_stop_from_json(*it);
      if (!stop) throw Error("'vignetting_stop' must be [radius, distance] in metres, or null");
      a.stop = *stop;
    }
    if (auto v = optional_number(body, "axial_ca")) a.axial_ca = *v;
    if (auto v = optional_number(body, "lateral_ca")) a.lateral_ca = *v;
    if (auto it = body.find("aperture_profile"); it != body.end()) {
      if (!it->is_string()) throw Error("'aperture_profile' must be uniform, centre or rim");
      a.profile = lens::parse_aperture_profile(it->get<std::string>());
    }
    if (auto v = optional_number(body, "aperture_profile_strength")) a.profile_strength = *v;
    if (auto it = body.find("aperture_image"); it != body.end()) {
      if (!it->is_null() && !it->is_string())
        throw Error("'aperture_image' must be a file name or null");
      a.image = it->is_null() ? std::string() : it->get<std::string>();
      if (!a.image.empty()) lens::Aperture{a};  // unreadable: refused here, changing nothing
    }
    for (auto [key, x, y] : {std::tuple{"lens_tilt", &a.tilt_x_deg, &a.tilt_y_deg},
                             std::tuple{"lens_shift", &a.shift_x, &a.shift_y}})
      if (auto it = body.find(key); it != body.end()) {
        const auto pair = lens::number_pair_from_json(*it);
        if (!pair) throw Error(std::string("'") + key + "' must be [x, y]");
        *x = pair->first, *y = pair->second;
      }
    std::optional<preview::PreviewMethod> method;
    if (auto it = body.find("method"); it != body.end()) {
      if (!it->is_string()) throw Error("'method' must be a string");
      method = preview::parse_preview_method(it->get<std::string>());
    }
    std::optional<preview::LayerComposite> composite;
    if (auto it = body.find("composite"); it != body.end()) {
      if (!it->is_string()) throw Error("'composite' must be a string");
      composite = preview::parse_layer_composite(it->get<std::string>());
    }
    session_.set_lens(lens);  // validates first, so a bad lens changes nothing
    if (method) session_.set_method(*method);
    if (composite) session_.set_composite(*composite);
    return json_response(lens_and_method_json(session_.status()));
  }
  // {x, y}: pixel of the image; focuses at the depth seen there.
  if (post && path == "/api/focus") {
    const json body = body_object(req);
    check_keys(body, {"x", "y"});
    const Pixel p = pixel(optional_number(body, "x"), optional_number(body, "y"));
    return json_response(lens_json(session_.focus_at(p.x, p.y)));
  }
  // {points: [[x, y], [x, y], [x, y]]}: pixels of the image; tilts the lens so that the plane of
  // focus passes through what is seen at all three (lens::focus_plane_through).
  if (post && path == "/api/focus_plane") {
    const json body = body_object(req);
    check_keys(body, {"points"});
    const auto it = body.find("points");
    if (it == body.end() || !it->is_array() || it->size() != 3)
      throw Error("'points' must be three [x, y] pixels");
    int pixels[3][2];
    for (int k = 0; k < 3; ++k) {
      const json& q = (*it)[k];
      if (!q.is_array() || q.size() != 2 || !q[0].is_number() || !q[1].is_number())
        throw Error("'points' must be three [x, y] pixels");
      const Pixel p = pixel(q[0].get<double>(), q[1].get<double>());
      pixels[k][0] = p.x, pixels[k][1] = p.y;
    }
    return json_response(lens_json(session_.focus_plane_at(pixels)));
  }
  // ?x=X&y=Y: the depth seen there (null: nothing).
  if (get && path == "/api/depth") {
    const Pixel p = pixel(number_param(req, "x"), number_param(req, "y"));
    const double d = session_.depth_at(p.x, p.y);
    return json_response({{"depth", std::isfinite(d) ? json(d) : json(nullptr)}});
  }
  if (get && path == "/api/image") return image(req);
  if (get && path == "/api/compare") {
    const std::optional<image::ErrorMetrics> m = session_.compare();
    if (!m) return error(503, "no reference for the current lens yet");
    return json_response({{"rel_mse", m->rel_mse},
                          {"psnr", m->psnr},
                          {"ssim", m->ssim},
                          {"reference_spp", session_.status().reference_spp}});
  }
  // {yaw, pitch (degrees), dolly (metres)}, each optional: moves the camera (ViewSession::
  // move_camera); the inputs are rendered again and the reference restarts.
  if (post && path == "/api/camera") {
    const json body = body_object(req);
    check_keys(body, {"yaw", "pitch", "dolly"});
    constexpr double kRadians = M_PI / 180.0;
    const scene::Camera c =
        session_.move_camera(optional_number(body, "yaw").value_or(0) * kRadians,
                             optional_number(body, "pitch").value_or(0) * kRadians,
                             optional_number(body, "dolly").value_or(0));
    return json_response(camera_json(c, session_.status()));
  }
  // Appends the camera and the lens as a key of the keyframe file given with --keyframes, for
  // `dofcache sequence --path`.
  if (post && path == "/api/keyframe") {
    if (keyframes_.empty() || !append_keyframe_)
      return error(409, "no keyframe file: start dofcache view with --keyframes FILE");
    // Through a real lens the key's focus counts from the sensor, as `sequence --lens-file`
    // reads it.
    const ViewStatus status = session_.status();
    lens::ThinLens lens = status.lens;
    lens.focus_distance = focus_from_camera(status.lens, status.real_lens);
    const int keys = append_keyframe_(keyframes_, session_.camera(), lens,
                                      "keys from dofcache view of " + scene_name_);
    return json_response({{"keys", keys}, {"file", keyframes_}, {"lens", lens_json(lens)}});
  }
  // The lens as a glTF camera node's extras (docs/scenes.md), ready to paste.
  if (get && path == "/api/lens.gltf")
    return json_response({{"extras", {{"lens", lens_json(session_.lens())}}}});
  return error(404, "no such route");
}

}  // namespace dofcache::view
