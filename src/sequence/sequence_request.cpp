#include "dofcache/cache/radiance_cache.h"
#include "dofcache/sequence/sequence_request.h"

#include <algorithm>
#include <tuple>

#include <fmt/format.h>
#include <glm/trigonometric.hpp>

#include "dofcache/core/error.h"
#include "dofcache/lens/lens_json.h"
#include "dofcache/request/image_render.h"

namespace dofcache::sequence {

PreparedSequence prepare_sequence(const request::RenderRequest& request) {
  if (request.kind != request::Kind::Sequence)
    throw Error(std::string("a sequence needs a request of kind sequence, not ") +
                request::kind_name(request.kind));
  const request::SequenceChoices& q = request.sequence;
  PreparedSequence p;
  p.scene = std::make_unique<scene::Scene>(
      render::load_scene(request.scene, request.scene_index, request.limits));
  const scene::Scene& scene = *p.scene;
  p.camera = &scene.camera_or_first(request.camera);
  const scene::Camera& camera = *p.camera;
  p.accel = std::make_unique<scene::Accel>(scene);

  if (!q.path.empty()) {
    p.path = load_keyframe_path(q.path, camera);
  } else if (request.scene.empty()) {
    throw Error("the built-in scene has no animation: give a keyframe file with --path");
  } else {
    p.path = load_gltf_camera_path(request.scene, camera, q.animation);
  }
  p.fps = q.fps.value_or(p.path.fps.value_or(24.0));
  std::tie(p.first, p.last) =
      q.frames.empty() ? path_frame_range(p.path, p.fps) : parse_frame_range(q.frames);

  p.resolved = request::resolve(request, scene, *p.accel, camera);
  const request::RenderRequest& r = p.resolved.request;
  SequenceSettings& s = p.settings;
  s.render = p.resolved.settings;
  s.cache_mode = r.cache == cache::kNoCache ? CacheMode::None
                 : q.persistent    ? CacheMode::Persistent
                                   : CacheMode::Fresh;
  s.cache_backend = r.cache == cache::kNoCache ? cache::kDefaultCacheBackend : r.cache;
  s.evict_after = q.evict_after;
  s.cache_memory_mb = q.cache_memory_mb;
  s.output = r.out;
  s.cache_in = q.cache_in;
  s.cache_any_lens = q.cache_any_lens;
  s.cache_out = q.cache_out;
  s.checkpoint = q.checkpoint;
  s.checkpoint_journal_ratio = q.checkpoint_journal;
  s.resume = !q.restart;
  s.temporal_window = r.sequence.temporal;  // resolved: the output's default filled in
  s.temporal_output = r.sequence.temporal_output;
  s.validate();  // before planning frames (which may probe the scene for autofocus)

  p.frames = keep_every(plan_frames(scene, *p.accel, camera, p.path, p.fps, p.first, p.last,
                                    request.lens, s.render.width, s.render.height),
                        q.frame_step);
  return p;
}

std::string describe_start(const PreparedSequence& p) {
  const SequenceSettings& s = p.settings;
  const render::RenderSettings& r = s.render;
  std::string text = fmt::format(
      "scene    {}: {} triangles, camera '{}'\npath     {}, frames {}-{} at {:g} fps "
      "({:.3g}-{:.3g} s)\nrender   {}x{} {}, {} spp; cache {}{}{}\n",
      p.scene->source, p.scene->mesh.triangles.size(), p.camera->name, p.path.source, p.first,
      p.last, p.fps, p.first / p.fps, p.last / p.fps, r.width, r.height, render::mode_name(r.mode),
      r.spp, cache_mode_name(s.cache_mode),
      s.cache_mode == CacheMode::None ? std::string() : " (" + s.cache_backend + ")",
      !r.lens_features        ? ""
      : s.temporal_window > 0 ? fmt::format("; each frame denoised, then filtered with {} frames "
                                            "on each side into {}",
                                            s.temporal_window, s.temporal_output)
                              : "; each frame denoised");
  if (const lens::MountedLens& m = p.frames.front().real_lens) {
    // Per frame: each is mounted at its own focus, so its field of view breathes.
    const auto [lo, hi] = std::minmax_element(
        p.frames.begin(), p.frames.end(),
        [](const FrameSpec& a, const FrameSpec& b) { return a.real_lens.yfov() < b.real_lens.yfov(); });
    text += fmt::format("lens     {} ({:.1f} mm f/{:.3g}), focused per frame; vertical field of "
                        "view {:.2f}-{:.2f} degrees\n",
                        m.source, m.lens->cardinal().focal_length * 1000.0, m.lens->fstop(),
                        glm::degrees(lo->real_lens.yfov()), glm::degrees(hi->real_lens.yfov()));
  }
  if (p.frames.front().autofocus)
    text += "notice   no focus distance given: autofocus on the image centre, per frame\n";
  return text;
}

std::string describe_frame(const FrameReport& f, bool cached) {
  if (f.skipped) return fmt::format("frame {:4d}  complete already  {}\n", f.frame, f.path);
  if (!cached) return fmt::format("frame {:4d}  {:6.2f} s  wrote {}\n", f.frame, f.seconds(), f.path);
  const cache::FrameCacheStats& c = f.cache;
  return fmt::format(
      "frame {:4d}  {:6.2f} s  reuse {:5.1f}%  hits {:5.1f}%  +{} -{} samples  {} samples {:.2f} "
      "MB  wrote {}\n",
      f.frame, f.seconds(), 100.0 * c.reuse_rate(), 100.0 * c.hit_rate(), c.inserted,
      c.evicted_unused + c.evicted_memory, c.samples_at_end, c.memory_bytes / 1e6, f.path);
}

std::string describe_summary(const SequenceSummary& sum) {
  std::string text = fmt::format("sequence {} frames rendered, {} complete already, {:.2f} s",
                                 sum.rendered, sum.skipped, sum.seconds);
  if (sum.reuse_frames > 0)
    text += fmt::format(", mean reuse {:.1f}% after the first frame",
                        100.0 * sum.reuse_sum / sum.reuse_frames);
  return text + "\n";
}

namespace {

// A frame's camera as another renderer needs it to render the same view: the camera-to-world
// matrix (column-major, as a glTF node's "matrix": looks down -Z, +Y up, Y-up world) and the
// vertical field of view in radians.
nlohmann::json frame_camera_json(const FrameSpec& spec) {
  nlohmann::json m = nlohmann::json::array();
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) m.push_back(spec.camera.camera_to_world[c][r]);
  return {{"camera_to_world", m}, {"yfov", spec.camera.yfov}};
}

}  // namespace

nlohmann::json frame_stats_json(const FrameReport& f) {
  // A real lens: mounted for this frame's focus (its field of view breathes with it).
  const nlohmann::json real =
      f.spec.real_lens ? lens::real_lens_json(f.spec.real_lens) : nlohmann::json(nullptr);
  if (f.skipped)
    return {{"frame", f.frame}, {"skipped", true}, {"output", f.path},
            {"camera", frame_camera_json(f.spec)}, {"lens", lens::lens_json(f.spec.lens)},
            {"real_lens", real}};
  const cache::FrameCacheStats& c = f.cache;
  return {{"frame", f.frame}, {"skipped", false}, {"output", f.path},
          {"camera", frame_camera_json(f.spec)}, {"lens", lens::lens_json(f.spec.lens)},
          {"real_lens", real},
          {"seconds", f.seconds()}, {"render_seconds", f.render_seconds},
          {"cache_seconds", f.cache_seconds}, {"write_seconds", f.write_seconds},
          {"denoise_seconds", f.denoise_seconds},
          {"rays", f.output.stats.rays}, {"shading_points", f.output.stats.shading_points},
          {"cache_lookups", c.lookups}, {"cache_hits", c.hits}, {"cache_reused", c.reused},
          {"reuse_rate", c.reuse_rate()}, {"samples_inserted", c.inserted},
          {"samples_shrunk", c.shrunk}, {"samples_grown", c.grown},
          {"evicted_unused", c.evicted_unused}, {"evicted_memory", c.evicted_memory},
          {"samples", c.samples_at_end}, {"cache_memory_bytes", c.memory_bytes},
          {"checkpoint_bytes", f.checkpoint_bytes}, {"checkpoint_full", f.checkpoint_full},
          {"checkpoint_seconds", f.checkpoint_seconds},
          {"checkpoint_cpu_seconds", f.checkpoint_cpu_seconds}};
}

std::string describe_temporal_frame(const TemporalFrameReport& f) {
  return fmt::format("temporal {:4d}  {:6.2f} s  {} neighbours  wrote {}\n", f.frame, f.seconds,
                     f.neighbours, f.path);
}

nlohmann::json temporal_stats_json(const TemporalFrameReport& f) {
  return {{"frame", f.frame}, {"output", f.path}, {"neighbours", f.neighbours},
          {"seconds", f.seconds}};
}

nlohmann::json sequence_stats_json(const PreparedSequence& p, const SequenceSummary& sum,
                                   const nlohmann::json& rows,
                                   const nlohmann::json& temporal_rows) {
  const SequenceSettings& s = p.settings;
  const render::RenderSettings& r = s.render;
  nlohmann::json j = {
      {"scene", p.scene->source}, {"path", p.path.source}, {"fps", p.fps},
      {"frames", {p.first, p.last}}, {"width", r.width}, {"height", r.height}, {"spp", r.spp},
      {"mode", render::mode_name(r.mode)}, {"seed", r.seed},
      {"cache", request::cache_json(s.cache_backend, r.cache)},
      {"environment",
       request::environment_json(p.resolved.request.environment, p.resolved.environment)},
      {"rendered", sum.rendered}, {"skipped", sum.skipped},
      {"resumed_after", sum.resumed_after}, {"seconds", sum.seconds}, {"per_frame", rows}};
  j["cache"].update({{"mode", cache_mode_name(s.cache_mode)},
                     {"evict_after", s.evict_after}, {"memory_mb", s.cache_memory_mb}});
  if (!temporal_rows.is_null())
    j["temporal"] = {{"window", s.temporal_window},
                     {"output", s.temporal_output},
                     {"per_frame", temporal_rows}};
  return j;
}

}  // namespace dofcache::sequence
