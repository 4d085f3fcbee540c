#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>

#include "commands.h"
#include "common_options.h"
#include "dofcache/cache/radiance_cache.h"
#include "dofcache/core/error.h"
#include "dofcache/render/renderer.h"
#include "dofcache/render/setup.h"
#include "dofcache/scene/accel.h"
#include "dofcache/sequence/camera_path.h"
#include "dofcache/sequence/sequence_renderer.h"

namespace dofcache::cli {
namespace {

struct SequenceOptions {
  std::string scene_path, out = "frames/####.png", camera, mode = "drt", path, animation, frames;
  std::string stats_json;
  std::optional<double> fps;
  int scene_index = -1, width = 320, height = 0, spp = 16, threads = 0;
  std::uint64_t seed = 1;
  std::optional<double> fstop, focal_length, focus_distance;
  render::ShadingSettings shading;
  std::string cache = "none", radius_rule = "paper";
  bool persistent = false, cache_given = false, restart = false, quiet = false;
  render::CacheSettings cache_settings;
  int evict_after = 8;
  double cache_memory_mb = 0.0;
  std::string cache_in, cache_out, checkpoint;
};

int run_sequence(const SequenceOptions& o) {
  scene::Scene scene = render::load_scene(o.scene_path, o.scene_index);
  for (const std::string& w : scene.warnings) std::fprintf(stderr, "dofcache: warning: %s\n", w.c_str());
  const scene::Camera& camera = scene.camera_or_first(o.camera);
  scene::Accel accel(scene);

  sequence::CameraPath path;
  if (!o.path.empty()) {
    path = sequence::load_keyframe_path(o.path, camera);
  } else if (o.scene_path.empty()) {
    throw Error("the built-in scene has no animation: give a keyframe file with --path");
  } else {
    path = sequence::load_gltf_camera_path(o.scene_path, camera, o.animation);
  }
  const double fps = o.fps.value_or(path.fps.value_or(24.0));
  auto [first, last] = o.frames.empty() ? sequence::path_frame_range(path, fps)
                                        : sequence::parse_frame_range(o.frames);

  sequence::SequenceSettings s;
  render::RenderSettings& r = s.render;
  r.width = o.width;
  r.height = o.height > 0 ? o.height : render::height_for_width(camera, o.width);
  r.spp = o.spp;
  r.mode = render::parse_mode(o.mode);
  r.seed = o.seed;
  r.threads = o.threads;
  r.shading = o.shading;
  r.cache = o.cache_settings;
  r.cache.radius_rule = render::parse_radius_rule(o.radius_rule);
  r.progress = o.quiet ? Progress::Display::Never : Progress::Display::Auto;
  // --persistent alone means the OpenVDB cache.
  std::string backend = o.persistent && !o.cache_given ? std::string("vdb") : o.cache;
  s.cache_mode = backend == "none"  ? sequence::CacheMode::None
                 : o.persistent     ? sequence::CacheMode::Persistent
                                    : sequence::CacheMode::Fresh;
  if (o.persistent && backend == "none")
    throw Error("--persistent needs a cache (--cache octree or vdb)");
  s.cache_backend = backend == "none" ? "vdb" : backend;
  s.evict_after = o.evict_after;
  s.cache_memory_mb = o.cache_memory_mb;
  s.output = o.out;
  s.cache_in = o.cache_in;
  s.cache_out = o.cache_out;
  s.checkpoint = o.checkpoint;
  s.resume = !o.restart;
  s.validate();  // before planning frames (which may probe the scene for autofocus)

  std::vector<sequence::FrameSpec> frames = sequence::plan_frames(
      scene, accel, camera, path, fps, first, last, {o.focal_length, o.fstop, o.focus_distance});
  sequence::SequenceRenderer renderer(scene, accel, frames, s);

  if (!o.quiet) {
    std::printf("scene    %s: %zu triangles, camera '%s'\n", scene.source.c_str(),
                scene.mesh.triangles.size(), camera.name.c_str());
    std::printf("path     %s, frames %d-%d at %g fps (%.3g-%.3g s)\n", path.source.c_str(), first,
                last, fps, first / fps, last / fps);
    std::string backend_note =
        s.cache_mode == sequence::CacheMode::None ? "" : " (" + s.cache_backend + ")";
    std::printf("render   %dx%d %s, %d spp; cache %s%s\n", r.width, r.height,
                render::mode_name(r.mode), r.spp, sequence::cache_mode_name(s.cache_mode),
                backend_note.c_str());
    if (frames.front().autofocus)
      std::printf("notice   no focus distance given: autofocus on the image centre, per frame\n");
  }

  nlohmann::json rows = nlohmann::json::array();
  double reuse_sum = 0.0;
  int reuse_frames = 0;
  auto on_frame = [&](const sequence::FrameReport& f) {
    if (f.skipped) {
      if (!o.quiet) std::printf("frame %4d  complete already  %s\n", f.frame, f.path.c_str());
      rows.push_back({{"frame", f.frame}, {"skipped", true}, {"output", f.path}});
      return;
    }
    const sequence::FrameCacheStats& c = f.cache;
    if (s.cache_mode != sequence::CacheMode::None && f.index > 0) {
      reuse_sum += c.reuse_rate();
      ++reuse_frames;
    }
    if (!o.quiet) {
      if (s.cache_mode == sequence::CacheMode::None)
        std::printf("frame %4d  %6.2f s  wrote %s\n", f.frame, f.seconds(), f.path.c_str());
      else
        std::printf("frame %4d  %6.2f s  reuse %5.1f%%  hits %5.1f%%  +%zu -%zu samples  "
                    "%zu samples %.2f MB  wrote %s\n",
                    f.frame, f.seconds(), 100.0 * c.reuse_rate(), 100.0 * c.hit_rate(), c.inserted,
                    c.evicted_unused + c.evicted_memory, c.samples_at_end, c.memory_bytes / 1e6,
                    f.path.c_str());
    }
    rows.push_back({{"frame", f.frame}, {"skipped", false}, {"output", f.path},
                    {"seconds", f.seconds()}, {"render_seconds", f.render_seconds},
                    {"cache_seconds", f.cache_seconds}, {"write_seconds", f.write_seconds},
                    {"rays", f.output.stats.rays},
                    {"shading_points", f.output.stats.shading_points},
                    {"cache_lookups", c.lookups}, {"cache_hits", c.hits},
                    {"cache_reused", c.reused}, {"reuse_rate", c.reuse_rate()},
                    {"samples_inserted", c.inserted}, {"samples_shrunk", c.shrunk},
                    {"samples_grown", c.grown}, {"evicted_unused", c.evicted_unused},
                    {"evicted_memory", c.evicted_memory}, {"samples", c.samples_at_end},
                    {"cache_memory_bytes", c.memory_bytes}});
  };
  auto notice = [&](const std::string& text) {
    if (!o.quiet) std::printf("notice   %s\n", text.c_str());
  };
  sequence::SequenceSummary sum = renderer.run(on_frame, notice);

  if (!o.stats_json.empty()) {
    nlohmann::json j = {
        {"scene", scene.source}, {"path", path.source}, {"fps", fps},
        {"frames", {first, last}}, {"width", r.width}, {"height", r.height}, {"spp", r.spp},
        {"mode", render::mode_name(r.mode)}, {"seed", r.seed},
        {"cache", {{"mode", sequence::cache_mode_name(s.cache_mode)},
                   {"backend", s.cache_backend}, {"min_factor", r.cache.min_factor},
                   {"radius_rule", o.radius_rule}, {"accuracy", r.cache.accuracy},
                   {"max_radius_pixels", r.cache.max_radius_pixels},
                   {"sample_quality", r.cache.sample_quality}, {"evict_after", s.evict_after},
                   {"memory_mb", s.cache_memory_mb}}},
        {"rendered", sum.rendered}, {"skipped", sum.skipped},
        {"resumed_after", sum.resumed_after}, {"seconds", sum.seconds}, {"per_frame", rows}};
    write_json_file(o.stats_json, j);
  }
  if (!o.quiet) {
    std::printf("sequence %d frames rendered, %d complete already, %.2f s", sum.rendered,
                sum.skipped, sum.seconds);
    if (reuse_frames > 0)
      std::printf(", mean reuse %.1f%% after the first frame", 100.0 * reuse_sum / reuse_frames);
    std::printf("\n");
  }
  std::printf("wrote    %s\n", std::filesystem::absolute(sequence::frame_path(o.out, first))
                                     .lexically_normal()
                                     .c_str());
  return 0;
}

}  // namespace

Runner add_sequence_command(CLI::App& app) {
  auto o = std::make_shared<SequenceOptions>();
  CLI::App* cmd = app.add_subcommand(
      "sequence",
      "Render the frames of a camera path (a glTF animation of the camera, or a keyframe file) "
      "in order; with --persistent the radiance cache is carried from frame to frame.");
  add_scene_options(cmd, o->scene_path, o->camera, o->scene_index);
  cmd->add_option("--path", o->path,
                  "JSON keyframe file (docs/sequence.md); default: the glTF animation that moves "
                  "the camera");
  cmd->add_option("--animation", o->animation, "glTF animation to use, by name or index");
  cmd->add_option("--frames", o->frames, "Frames A-B (default: every frame of the path)");
  cmd->add_option("--fps", o->fps, "Frames per second (default: the keyframe file's, else 24)")
      ->check(CLI::Range(1e-3, 1e4));
  cmd->add_option("-o,--out", o->out,
                  "Output pattern; a run of '#' becomes the zero-padded frame number. .png or "
                  ".exr (linear, with Z, N and id channels)")
      ->capture_default_str();
  add_size_options(cmd, o->width, o->height);
  cmd->add_option("--spp", o->spp, "Samples (lens rays) per pixel")->capture_default_str()
      ->check(CLI::Range(1, 1 << 20));
  cmd->add_option("--mode", o->mode, "drt, accumulation or pinhole")
      ->capture_default_str()
      ->check(CLI::IsMember({"pinhole", "drt", "accumulation"}));
  add_lens_options(cmd, o->fstop, o->focal_length, o->focus_distance);
  add_seed_and_threads(cmd, o->seed, o->threads,
                       "Random seed; each frame's seed is derived from it and the frame "
                       "number, so any subset of frames reproduces");
  add_shading_options(cmd, o->shading);
  cmd->add_option("--cache", o->cache,
                  "Radiance cache: none, octree or vdb (a fresh cache per frame unless "
                  "--persistent)")
      ->capture_default_str()
      ->check(CLI::IsMember(cache::radiance_cache_backends()))
      ->each([o](const std::string&) { o->cache_given = true; });
  cmd->add_flag("--persistent", o->persistent,
                "Carry the cache across frames (the vdb backend unless --cache says otherwise)");
  add_cache_tuning_options(cmd, o->cache_settings, o->radius_rule);
  cmd->add_option("--cache-evict-after", o->evict_after,
                  "Evict cache samples no lookup used for this many frames (0: never)")
      ->capture_default_str()->check(CLI::Range(0, 1 << 30));
  cmd->add_option("--cache-memory", o->cache_memory_mb,
                  "Cap the cache at this many MB, evicting the least recently used first "
                  "(0: no cap)")
      ->capture_default_str()->check(CLI::Range(0.0, 1e9));
  cmd->add_option("--cache-in", o->cache_in, "Start from this cache file (.vdb)");
  cmd->add_option("--cache-out", o->cache_out, "Save the cache to this file (.vdb) at the end");
  cmd->add_option("--checkpoint", o->checkpoint,
                  "Checkpoint of the persistent cache, written after every frame so an "
                  "interrupted run resumes (default: .<pattern>.checkpoint.vdb beside the frames)");
  cmd->add_flag("--restart", o->restart,
                "Render every frame again, ignoring complete frames and the checkpoint");
  cmd->add_option("--stats-json", o->stats_json, "Write per-frame statistics as JSON to this file");
  cmd->add_flag("-q,--quiet", o->quiet, "Print only the first frame's path");
  return [o] { return run_sequence(*o); };
}

}  // namespace dofcache::cli
