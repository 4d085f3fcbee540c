#include "dofcache/request/render_request.h"

#include <cmath>
#include <limits>
#include <set>
#include <sstream>
#include <type_traits>

#include <nlohmann/json.hpp>

#include "dofcache/cache/radiance_cache.h"
#include "dofcache/cache/sample_radius.h"
#include "dofcache/core/error.h"
#include "dofcache/core/file.h"
#include "dofcache/lens/lens_json.h"

namespace dofcache::request {

using nlohmann::json;

const char* kind_name(Kind kind) {
  switch (kind) {
    case Kind::Image: return "image";
    case Kind::Sequence: return "sequence";
    case Kind::View: return "view";
  }
  return "?";
}

Kind parse_kind(const std::string& name) {
  for (Kind k : {Kind::Image, Kind::Sequence, Kind::View})
    if (name == kind_name(k)) return k;
  throw Error("unknown request kind '" + name + "' (expected image, sequence or view)");
}

const char* choice_name(Choice choice) {
  switch (choice) {
    case Choice::Auto: return "auto";
    case Choice::On: return "on";
    case Choice::Off: return "off";
  }
  return "?";
}

Choice parse_choice(const std::string& name) {
  for (Choice c : {Choice::Auto, Choice::On, Choice::Off})
    if (name == choice_name(c)) return c;
  throw Error("'" + name + "' is not auto, on or off");
}

const std::vector<std::string>& choice_names() {
  static const std::vector<std::string> names = {"auto", "on", "off"};
  return names;
}

std::string mode_name(const Mode& mode) {
  return mode.preview ? preview::preview_method_name(*mode.preview)
                      : render::mode_name(mode.integrator);
}

std::vector<std::string> mode_names() {
  std::vector<std::string> names = render::mode_names();
  for (const std::string& n : preview::preview_method_names()) names.push_back(n);
  return names;
}

Mode parse_mode(const std::string& name) {
  for (const std::string& n : preview::preview_method_names())
    if (name == n) return {render::Mode::Pinhole, preview::parse_preview_method(n)};
  for (const std::string& n : render::mode_names())
    if (name == n) return {render::parse_mode(n), std::nullopt};
  std::string valid;
  for (const std::string& n : mode_names()) valid += (valid.empty() ? "" : ", ") + n;
  throw Error("unknown mode '" + name + "' (valid: " + valid + ")");
}

bool integrates_lens(const Mode& mode) {
  return !mode.preview && mode.integrator != render::Mode::Pinhole;
}

RenderRequest default_request(Kind kind) {
  RenderRequest r;
  r.kind = kind;
  render::CacheSettings& c = r.cache_settings;
  if (kind == Kind::Sequence) {
    r.width = 320;
    r.out = "frames/####.png";
    // Cache files record the sample quality and radius rule, so camera paths keep fixed ones.
    return r;
  }
  // A single image chooses the cache sample quality from its lens samples (measured best at
  // equal quality, docs/cache.md), and shades per ray the hits few lens rays would reuse.
  c.sample_quality = render::kAutoSampleQuality;
  c.radius.min_factor = cache::kSingleImageMinFactor;
  c.direct_below = render::kSingleImageDirectBelow;
  c.direct_cost_ratio = render::kSingleImageDirectCostRatio;
  if (kind == Kind::Image) r.out = "dofcache.png";
  if (kind == Kind::View) {
    r.core_policy = CorePolicy::LeaveOneCore;
    // The viewer's passes share one cache: a sample serves every later pass, so every hit is
    // cached, as in camera paths.
    c.direct_below = 0.0f;
    c.direct_cost_ratio = 0.0f;
  }
  return r;
}

// ---------------------------------------------------------------------------------------------
// JSON

json shading_json(const render::ShadingSettings& s) {
  return {{"light_samples", s.light_samples}, {"gather_rays", s.gather_rays},
          {"bounces", s.bounces}, {"specular_depth", s.specular_depth},
          {"rough_lobe_rate", s.rough_lobe_rate},
          {"material_override", render::material_override_name(s.material_override)}};
}

json cache_json(const std::string& backend, const render::CacheSettings& c) {
  return {{"backend", backend},
          {"radius_rule", cache::radius_rule_name(c.radius.rule)},
          {"min_factor", c.radius.min_factor},
          {"accuracy", c.radius.accuracy},
          {"max_radius_pixels", c.radius.max_radius_pixels},
          {"sample_quality", c.sample_quality},
          {"sample_error", c.sample_error},
          {"max_sample_rounds", c.max_sample_rounds},
          {"direct_below", c.direct_below},
          {"direct_cost_ratio", c.direct_cost_ratio},
          {"direct_light_samples", c.direct_light_samples},
          {"direct_gather_rays", c.direct_gather_rays},
          {"max_normal_angle_deg", c.lookup.max_normal_angle_deg},
          {"min_samples", c.lookup.min_samples}};
}

namespace {

json optional_number(const std::optional<double>& v) { return v ? json(*v) : json(nullptr); }

json environment_settings_json(const render::EnvironmentSettings& e) {
  json color = nullptr;
  if (e.color) color = {e.color->x, e.color->y, e.color->z};
  return {{"path", e.path},         {"color", color},
          {"strength", e.strength}, {"rotation_deg", e.rotation_degrees},
          {"visible", e.visible},   {"default_sky", e.default_sky}};
}

std::string text(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// [a, b], or null when unset.
json pair_json(const std::optional<std::pair<double, double>>& p) {
  return p ? json{p->first, p->second} : json(nullptr);
}

// Walks one JSON object of a request: every key must be known, every value of its type.
class Reader {
 public:
  Reader(const json& j, std::string where) : j_(j), where_(std::move(where)) {
    if (!j_.is_object()) fail("must be an object");
  }
  // Called once every key is read. Not a destructor: one that throws after the returned request
  // is built leaks it (compilers do not destroy an NRVO return value then, CWG 2176).
  void finish() const {
    for (auto it = j_.begin(); it != j_.end(); ++it)
      if (!seen_.count(it.key()))
        throw Error("request: unknown key '" + path(it.key()) + "'");
  }
  bool has(const char* key) {
    seen_.insert(key);
    return j_.contains(key) && !j_.at(key).is_null();
  }
  const json& at(const char* key) const { return j_.at(key); }
  std::string path(const std::string& key) const {
    return where_.empty() ? key : where_ + "." + key;
  }
  [[noreturn]] void fail(const std::string& what, const char* key = nullptr) const {
    throw Error("request: '" + (key ? path(key) : where_) + "' " + what);
  }

  void get(const char* key, std::string& v) {
    if (!has(key)) return;
    if (!at(key).is_string()) fail("must be a string", key);
    v = at(key).get<std::string>();
  }
  void get(const char* key, bool& v) {
    if (!has(key)) return;
    if (!at(key).is_boolean()) fail("must be true or false", key);
    v = at(key).get<bool>();
  }
  template <class T>
  void get(const char* key, T& v, double lo, double hi) {
    if (!has(key)) return;
    v = number<T>(key, lo, hi);
  }
  template <class T>
  void get(const char* key, std::optional<T>& v, double lo, double hi) {
    seen_.insert(key);
    if (!j_.contains(key) || j_.at(key).is_null()) {
      if (j_.contains(key)) v.reset();  // null: back to automatic
      return;
    }
    v = number<T>(key, lo, hi);
  }
  template <class T>
  T number(const char* key, double lo, double hi) const {
    const json& x = at(key);
    if (!x.is_number()) fail("must be a number", key);
    const double d = x.get<double>();
    if (!(d >= lo && d <= hi))
      fail("must be in [" + text(lo) + ", " + text(hi) + "], got " + x.dump(), key);
    if (std::is_integral<T>::value && d != std::floor(d)) fail("must be a whole number", key);
    if (std::is_unsigned<T>::value) return static_cast<T>(x.get<std::uint64_t>());
    return static_cast<T>(std::is_integral<T>::value ? x.get<std::int64_t>() : d);
  }

 private:
  const json& j_;
  std::string where_;
  std::set<std::string> seen_;
};

template <class F>
void object(Reader& parent, const char* key, F&& read) {
  if (!parent.has(key)) return;
  Reader r(parent.at(key), parent.path(key));
  read(r);
  r.finish();
}

// Applies a name through `parse`, turning its error into one naming the key.
template <class T, class Parse>
void named(Reader& r, const char* key, T& v, Parse parse) {
  std::string name;
  r.get(key, name);
  if (!r.has(key)) return;
  try {
    v = parse(name);
  } catch (const Error& e) {
    r.fail(std::string("is invalid: ") + e.what(), key);
  }
}

constexpr double kBig = 1e9;
constexpr double kMaxU64 = 1.8e19;

}  // namespace

json to_json(const RenderRequest& r) {
  const render::CacheSettings& c = r.cache_settings;
  const render::AdaptiveSampling& a = r.adaptive_settings;
  json j = {
      {"kind", kind_name(r.kind)},
      {"scene",
       {{"path", r.scene},
        {"camera", r.camera},
        {"index", r.scene_index},
        {"limits",
         {{"max_vertices", r.limits.max_vertices},
          {"max_triangles", r.limits.max_triangles},
          {"max_texture_pixels", r.limits.max_texture_pixels},
          {"max_node_depth", r.limits.max_node_depth}}}}},
      {"image", {{"width", r.width}, {"height", r.height}}},
      {"mode", mode_name(r.mode)},
      {"spp", r.spp ? json(*r.spp) : json(nullptr)},
      {"seed", r.seed},
      {"pattern_seed", r.pattern_seed ? json(*r.pattern_seed) : json(nullptr)},
      {"threads", r.threads},
      {"leave_one_core", r.core_policy == CorePolicy::LeaveOneCore},
      {"lens",
       {{"focal_length", optional_number(r.lens.focal_length)},
        {"fstop", optional_number(r.lens.fstop)},
        {"focus_distance", optional_number(r.lens.focus_distance)},
        {"aperture_blades", r.lens.aperture.blades ? json(*r.lens.aperture.blades) : json(nullptr)},
        {"aperture_rotation", optional_number(r.lens.aperture.rotation_deg)},
        {"aperture_roundness", optional_number(r.lens.aperture.roundness)},
        {"anamorphic_ratio", optional_number(r.lens.aperture.anamorphic_ratio)},
        {"vignetting_stop", r.lens.aperture.vignetting_stop
                                ? json{r.lens.aperture.vignetting_stop->radius,
                                       r.lens.aperture.vignetting_stop->distance}
                                : json(nullptr)},
        {"axial_ca", optional_number(r.lens.aperture.axial_ca)},
        {"lateral_ca", optional_number(r.lens.aperture.lateral_ca)},
        {"aperture_profile", r.lens.aperture.profile
                                 ? json(lens::aperture_profile_name(*r.lens.aperture.profile))
                                 : json(nullptr)},
        {"aperture_profile_strength", optional_number(r.lens.aperture.profile_strength)},
        {"lens_tilt", pair_json(r.lens.aperture.lens_tilt)},
        {"lens_shift", pair_json(r.lens.aperture.lens_shift)},
        {"aperture_image", r.lens.aperture.image ? json(*r.lens.aperture.image) : json(nullptr)},
        {"lens_file", r.lens.real.file.empty() ? json(nullptr) : json(r.lens.real.file)},
        {"sensor_size", {r.lens.real.sensor.width, r.lens.real.sensor.height}},
        {"sensor_fit", lens::sensor_fit_name(r.lens.real.sensor.fit)},
        {"exposure_follows_lens", r.lens.real.exposure_follows_lens}}},
      {"shading", r.shading ? shading_json(*r.shading) : json(nullptr)},
      {"environment", environment_settings_json(r.environment)},
      {"cache", cache_json(r.cache, c)},
      {"adaptive",
       {{"mode", choice_name(r.adaptive)},
        {"pilot_fraction", a.pilot_fraction},
        {"min_factor", a.min_factor},
        {"max_factor", a.max_factor}}},
      {"denoise", choice_name(r.denoise)},
      {"preview",
       {{"composite", preview::layer_composite_name(r.composite)}, {"edge_rays", r.edge_rays}}},
      {"outputs",
       {{"image", r.out},
        {"stats_json", r.stats_json},
        {"preview_inputs", r.preview_inputs},
        {"cache_debug", r.cache_debug},
        {"cache_trace", r.cache_trace},
        {"quiet", r.quiet}}}};
  if (r.kind == Kind::Sequence) {
    const SequenceChoices& s = r.sequence;
    j["sequence"] = {{"path", s.path},
                     {"animation", s.animation},
                     {"frames", s.frames},
                     {"frame_step", s.frame_step},
                     {"fps", optional_number(s.fps)},
                     {"persistent", s.persistent},
                     {"evict_after", s.evict_after},
                     {"cache_memory_mb", s.cache_memory_mb},
                     {"cache_in", s.cache_in},
                     {"cache_any_lens", s.cache_any_lens},
                     {"cache_out", s.cache_out},
                     {"checkpoint", s.checkpoint},
                     {"checkpoint_journal", s.checkpoint_journal},
                     {"restart", s.restart},
                     {"temporal", s.temporal},
                     {"temporal_output", s.temporal_output},
                     {"temporal_only", s.temporal_only}};
  }
  return j;
}

RenderRequest request_from_json(const json& j) {
  Reader top(j, "");
  Kind kind = Kind::Image;
  named(top, "kind", kind, parse_kind);
  RenderRequest r = default_request(kind);
  object(top, "scene", [&](Reader& s) {
    s.get("path", r.scene);
    s.get("camera", r.camera);
    s.get("index", r.scene_index, -1, kBig);
    object(s, "limits", [&](Reader& l) {
      l.get("max_vertices", r.limits.max_vertices, 1, kMaxU64);
      l.get("max_triangles", r.limits.max_triangles, 1, kMaxU64);
      l.get("max_texture_pixels", r.limits.max_texture_pixels, 1, kMaxU64);
      l.get("max_node_depth", r.limits.max_node_depth, 1, 100000);
    });
  });
  object(top, "image", [&](Reader& i) {
    i.get("width", r.width, 1, 16384);
    i.get("height", r.height, 0, 16384);
  });
  named(top, "mode", r.mode, parse_mode);
  top.get("spp", r.spp, 1, 1 << 20);
  top.get("seed", r.seed, 0, kMaxU64);
  top.get("pattern_seed", r.pattern_seed, 0, kMaxU64);
  top.get("threads", r.threads, 0, 4096);
  bool leave_one = r.core_policy == CorePolicy::LeaveOneCore;
  top.get("leave_one_core", leave_one);
  r.core_policy = leave_one ? CorePolicy::LeaveOneCore : CorePolicy::AllCores;
  object(top, "lens", [&](Reader& l) {
    l.get("focal_length", r.lens.focal_length, 1e-6, 1e3);
    l.get("fstop", r.lens.fstop, 1e-3, 1e6);
    l.get("focus_distance", r.lens.focus_distance, 1e-6, 1e9);
    l.get("aperture_blades", r.lens.aperture.blades, 0, lens::kMaxBlades);
    l.get("aperture_rotation", r.lens.aperture.rotation_deg, -1e6, 1e6);
    l.get("aperture_roundness", r.lens.aperture.roundness, 0, 1);
    l.get("anamorphic_ratio", r.lens.aperture.anamorphic_ratio, 1e-2, 1e2);
    if (l.has("vignetting_stop")) {
      r.lens.aperture.vignetting_stop = lens::vignetting_stop_from_json(l.at("vignetting_stop"));
      if (!r.lens.aperture.vignetting_stop)
        l.fail("must be [radius, distance] in metres (or null)", "vignetting_stop");
    }
    l.get("axial_ca", r.lens.aperture.axial_ca, -1e3, 1e3);
    l.get("lateral_ca", r.lens.aperture.lateral_ca, -0.2, 0.2);
    if (l.has("aperture_profile")) {
      lens::ApertureProfile profile{};
      named(l, "aperture_profile", profile, lens::parse_aperture_profile);
      r.lens.aperture.profile = profile;
    }
    l.get("aperture_profile_strength", r.lens.aperture.profile_strength, 0, 1);
    if (l.has("aperture_image")) {
      std::string path;
      l.get("aperture_image", path);
      r.lens.aperture.image = path;
    }
    for (auto [key, field] : {std::pair{"lens_tilt", &r.lens.aperture.lens_tilt},
                              std::pair{"lens_shift", &r.lens.aperture.lens_shift}})
      if (l.has(key)) {
        *field = lens::number_pair_from_json(l.at(key));
        if (!*field) l.fail("must be [x, y] (or null)", key);
      }
    l.get("lens_file", r.lens.real.file);
    if (l.has("sensor_size")) {
      const auto size = lens::number_pair_from_json(l.at("sensor_size"));
      if (!size) l.fail("must be [width, height] in metres", "sensor_size");
      r.lens.real.sensor.width = size->first;
      r.lens.real.sensor.height = size->second;
    }
    named(l, "sensor_fit", r.lens.real.sensor.fit, lens::parse_sensor_fit);
    l.get("exposure_follows_lens", r.lens.real.exposure_follows_lens);
  });
  if (top.has("shading")) {
    render::ShadingSettings sh;
    object(top, "shading", [&](Reader& s) {
      s.get("light_samples", sh.light_samples, 0, 4096);
      s.get("gather_rays", sh.gather_rays, 0, 65536);
      s.get("bounces", sh.bounces, 0, 16);
      s.get("specular_depth", sh.specular_depth, 0, 16);
      s.get("rough_lobe_rate", sh.rough_lobe_rate, 0, 1e3);
      named(s, "material_override", sh.material_override, render::parse_material_override);
    });
    r.shading = sh;
  }
  object(top, "environment", [&](Reader& e) {
    render::EnvironmentSettings& env = r.environment;
    e.get("path", env.path);
    if (e.has("color")) {
      const json& c = e.at("color");
      if (!c.is_array() || c.size() != 3 || !c[0].is_number() || !c[1].is_number() ||
          !c[2].is_number())
        e.fail("must be three numbers (or null)", "color");
      env.color = glm::vec3(c[0].get<float>(), c[1].get<float>(), c[2].get<float>());
    }
    e.get("strength", env.strength, 0, 1e6);
    e.get("rotation_deg", env.rotation_degrees, -1e6, 1e6);
    e.get("visible", env.visible);
    e.get("default_sky", env.default_sky);
  });
  object(top, "cache", [&](Reader& c) {
    render::CacheSettings& cs = r.cache_settings;
    c.get("backend", r.cache);
    named(c, "radius_rule", cs.radius.rule, cache::parse_radius_rule);
    c.get("min_factor", cs.radius.min_factor, 1e-3, 1e4);
    c.get("accuracy", cs.radius.accuracy, 1e-3, 10);
    c.get("max_radius_pixels", cs.radius.max_radius_pixels, 0, 1e4);
    c.get("sample_quality", cs.sample_quality, 0, 256);
    c.get("sample_error", cs.sample_error, 1e-3, 10);
    c.get("max_sample_rounds", cs.max_sample_rounds, 1, 64);
    c.get("direct_below", cs.direct_below, 0, 1e6);
    c.get("direct_cost_ratio", cs.direct_cost_ratio, 0, 1e6);
    c.get("direct_light_samples", cs.direct_light_samples, 0, 4096);
    c.get("direct_gather_rays", cs.direct_gather_rays, 0, 4096);
    c.get("max_normal_angle_deg", cs.lookup.max_normal_angle_deg, 0.1, 90);
    c.get("min_samples", cs.lookup.min_samples, 1, 1024);
  });
  object(top, "adaptive", [&](Reader& a) {
    named(a, "mode", r.adaptive, parse_choice);
    a.get("pilot_fraction", r.adaptive_settings.pilot_fraction, 1e-3, 1);
    a.get("min_factor", r.adaptive_settings.min_factor, 0, 1);
    a.get("max_factor", r.adaptive_settings.max_factor, 1, 1024);
  });
  named(top, "denoise", r.denoise, parse_choice);
  object(top, "preview", [&](Reader& p) {
    named(p, "composite", r.composite, preview::parse_layer_composite);
    p.get("edge_rays", r.edge_rays, 0, 1024);
  });
  object(top, "outputs", [&](Reader& o) {
    o.get("image", r.out);
    o.get("stats_json", r.stats_json);
    o.get("preview_inputs", r.preview_inputs);
    o.get("cache_debug", r.cache_debug);
    o.get("cache_trace", r.cache_trace);
    o.get("quiet", r.quiet);
  });
  object(top, "sequence", [&](Reader& s) {
    if (kind != Kind::Sequence) s.fail("is only for requests of kind sequence");
    SequenceChoices& q = r.sequence;
    s.get("path", q.path);
    s.get("animation", q.animation);
    s.get("frames", q.frames);
    s.get("frame_step", q.frame_step, 1, 1 << 30);
    s.get("fps", q.fps, 1e-3, 1e4);
    s.get("persistent", q.persistent);
    s.get("evict_after", q.evict_after, 0, 1 << 30);
    s.get("cache_memory_mb", q.cache_memory_mb, 0, 1e9);
    s.get("cache_in", q.cache_in);
    s.get("cache_any_lens", q.cache_any_lens);
    s.get("cache_out", q.cache_out);
    s.get("checkpoint", q.checkpoint);
    s.get("checkpoint_journal", q.checkpoint_journal, 0, 1e6);
    s.get("restart", q.restart);
    s.get("temporal", q.temporal, 0, kMaxTemporalWindow);
    s.get("temporal_output", q.temporal_output);
    s.get("temporal_only", q.temporal_only);
  });
  top.has("choices");  // written by resolved_json for the reader's information only
  top.finish();
  return r;
}

RenderRequest load_request(const std::string& path) {
  const std::string text = read_file(path, "request file");
  json j;
  try {
    j = json::parse(text);
  } catch (const json::exception& e) {
    throw Error(path + ": not JSON: " + one_line(e.what()));
  }
  try {
    return request_from_json(j);
  } catch (const Error& e) {
    throw Error(path + ": " + e.what());
  }
}

}  // namespace dofcache::request
