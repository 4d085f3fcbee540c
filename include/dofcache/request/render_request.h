#pragma once
// What a user asks for, declaratively: the one request every front end builds (the CLI's render
// and sequence commands, the viewer, the farm's jobs, the benchmarks). Fields left to `auto`
// (cache backend, adaptive sampling, samples and shading of the preview modes, cache sample
// quality, image height, lens focus, threads) are decided by resolve() (resolve.h), once, by the
// rules of the request's kind; everything else is taken as given. One JSON form, read and written
// here, is what `render --print-request` prints, `--request FILE` reads and the farm stores per
// job (docs/design.md, "From a command line to pixels").
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "dofcache/core/threads.h"
#include "dofcache/preview/options.h"
#include "dofcache/preview/preview.h"
#include "dofcache/render/environment.h"
#include "dofcache/render/renderer.h"
#include "dofcache/render/setup.h"
#include "dofcache/scene/gltf_loader.h"

namespace dofcache::request {

// Whose automatic rules and defaults apply: a single image (`render`), a camera path
// (`sequence`, the farm's jobs), or the viewer's background reference.
enum class Kind { Image, Sequence, View };
const char* kind_name(Kind kind);  // "image", "sequence", "view"
Kind parse_kind(const std::string& name);

// auto | on | off.
enum class Choice { Auto, On, Off };
const char* choice_name(Choice choice);
Choice parse_choice(const std::string& name);
const std::vector<std::string>& choice_names();

// The mode: an integrator of the renderer, or a preview method, whose inputs a pinhole render
// gives. Spelled as `render --mode` spells it: render::mode_names() and
// preview::preview_method_names().
struct Mode {
  render::Mode integrator = render::Mode::Drt;
  std::optional<preview::PreviewMethod> preview;
  bool operator==(const Mode& o) const {
    return integrator == o.integrator && preview == o.preview;
  }
};
std::string mode_name(const Mode& mode);
Mode parse_mode(const std::string& name);  // throws dofcache::Error listing the valid names
std::vector<std::string> mode_names();     // the integrators', then the previews'
// Whether `mode` integrates over the lens (drt, accumulation): the modes a radiance cache serves.
bool integrates_lens(const Mode& mode);

// The most frames on each side the temporal filter averages (17 frames in all).
constexpr int kMaxTemporalWindow = 8;

// The camera-path part of a sequence request (Kind::Sequence only).
struct SequenceChoices {
  std::string path;       // JSON keyframe file; empty: the glTF animation that moves the camera
  std::string animation;  // glTF animation by name or index; empty: the one moving the camera
  std::string frames;     // "A-B" or "A"; empty: every frame of the path
  int frame_step = 1;
  std::optional<double> fps;  // unset: the keyframe file's, else 24
  bool persistent = false;    // one cache carried across the frames
  int evict_after = 8;
  double cache_memory_mb = 0.0;
  std::string cache_in, cache_out, checkpoint;
  bool cache_any_lens = false;  // accept a cache_in made through a lens of another design
  double checkpoint_journal = 1.0;
  bool restart = false;
  // The temporal filter over the written frames (sequence/temporal_pass.h): frames on each side
  // (0: none), where the filtered frames go (empty: the output pattern with ".temporal" before
  // its extension), and whether to filter frames written already without rendering any.
  int temporal = 0;
  std::string temporal_output;
  bool temporal_only = false;
};

struct RenderRequest {
  Kind kind = Kind::Image;
  // --- scene ---
  std::string scene;   // .gltf/.glb; empty: the built-in Cornell box
  std::string camera;  // empty: the scene's first camera
  int scene_index = -1;
  scene::LoadLimits limits;
  // --- image ---
  int width = 640;
  int height = 0;          // 0: from the camera's aspect ratio
  std::optional<int> spp;  // unset: 16, or preview::kQuickInputSpp in the preview modes
  Mode mode;
  std::uint64_t seed = 1;
  // The pixels' film and lens patterns (RenderSettings::pattern_seed); unset: `seed`. A
  // sequence's frames use the sequence's seed here, so `render --seed S' --pattern-seed S`
  // reproduces a frame (S' = sequence::frame_seed(S, frame)).
  std::optional<std::uint64_t> pattern_seed;
  int threads = 0;  // 0: the cores `core_policy` gives (core/threads.h)
  CorePolicy core_policy = CorePolicy::AllCores;
  render::LensOverrides lens;  // each unset value: the camera's extras.lens, else the fallback
  // Unset: the renderer's defaults, or in the preview modes preview::quick_input_shading.
  std::optional<render::ShadingSettings> shading;
  render::EnvironmentSettings environment;
  // --- radiance cache ---
  std::string cache = "auto";  // auto, or one of cache::radiance_cache_backends() or "none"
  // Tuning (the cache pointer, frame and trace are set by whoever renders). sample_quality
  // render::kAutoSampleQuality: chosen from the lens samples.
  render::CacheSettings cache_settings;
  // --- adaptive lens sampling ---
  Choice adaptive = Choice::Auto;
  render::AdaptiveSampling adaptive_settings;  // `enabled` is decided by `adaptive`
  // --- denoising (denoise/atrous.h, render_filter.h): auto as resolve.h says ---
  Choice denoise = Choice::Auto;
  // --- the layered previews' composite ---
  preview::LayerComposite composite = preview::LayerComposite::Over;
  int edge_rays = preview::PreviewOptions{}.edge_rays;
  // --- outputs ---
  std::string out;             // image, or a sequence's frame pattern
  std::string stats_json;      // statistics file; empty: none
  std::string preview_inputs;  // preview modes: the pinhole inputs for `refocus` (.exr)
  std::string cache_debug;     // PREFIX of the cache's hit and density images
  std::string cache_trace;     // the cache's lookups and inserts, for the replay benchmark
  bool quiet = false;
  // --- camera paths ---
  SequenceChoices sequence;
};

// The defaults of each kind: an image is 640 wide with the single-image cache tuning (sample
// quality from the lens samples, kSingleImageMinFactor, kSingleImageDirectBelow) and writes
// dofcache.png; a sequence is 320 wide with the tuning that cache files record (a fixed sample
// quality, the paper's min factor, every hit cached) and writes frames/####.png; the viewer's
// reference uses the single-image tuning but caches every hit (its passes share one cache, so a
// sample serves every later pass) and leaves a core to the user (CorePolicy::LeaveOneCore).
RenderRequest default_request(Kind kind);

// The JSON form: every field, grouped as {"kind", "scene": {...}, "image": {...}, "mode", "spp",
// "seed", "threads", "core_policy", "lens": {...}, "shading": {...}, "environment": {...},
// "cache": {...}, "adaptive": {...}, "preview": {...}, "outputs": {...}, "sequence": {...}}.
// Reading starts from default_request(kind) and takes the keys present; an unknown key, a value
// of the wrong type or out of range is a one-line dofcache::Error naming it.
nlohmann::json to_json(const RenderRequest& request);
RenderRequest request_from_json(const nlohmann::json& json);
RenderRequest load_request(const std::string& path);  // a JSON file; errors name the file

// Pieces of the JSON form that statistics files repeat.
nlohmann::json shading_json(const render::ShadingSettings& shading);
nlohmann::json cache_json(const std::string& backend, const render::CacheSettings& cache);

}  // namespace dofcache::request
