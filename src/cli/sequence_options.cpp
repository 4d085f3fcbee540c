#include "sequence_options.h"

#include <tuple>

#include "common_options.h"
#include "dofcache/cache/radiance_cache.h"
#include "dofcache/core/error.h"
#include "dofcache/render/setup.h"

namespace dofcache::cli {

void add_sequence_options(CLI::App* cmd, SequenceOptions& o) {
  add_scene_options(cmd, o.scene_path, o.camera, o.scene_index, o.limits);
  cmd->add_option("--path", o.path,
                  "JSON keyframe file (docs/sequence.md); default: the glTF animation that moves "
                  "the camera");
  cmd->add_option("--animation", o.animation, "glTF animation to use, by name or index");
  cmd->add_option("--frames", o.frames, "Frames A-B (default: every frame of the path)");
  cmd->add_option("--frame-step", o.frame_step,
                  "Render every Nth frame of the range (and its last), e.g. keyframes that warm "
                  "a cache")
      ->capture_default_str()->check(CLI::Range(1, 1 << 30));
  cmd->add_option("--fps", o.fps, "Frames per second (default: the keyframe file's, else 24)")
      ->check(CLI::Range(1e-3, 1e4));
  cmd->add_option("-o,--out", o.out,
                  "Output pattern; a run of '#' becomes the zero-padded frame number. .png or "
                  ".exr (linear, with Z, N and id channels)")
      ->capture_default_str();
  add_size_options(cmd, o.width, o.height);
  cmd->add_option("--spp", o.spp, "Samples (lens rays) per pixel")->capture_default_str()
      ->check(CLI::Range(1, 1 << 20));
  cmd->add_option("--mode", o.mode, "drt, accumulation or pinhole")
      ->capture_default_str()
      ->check(CLI::IsMember({"pinhole", "drt", "accumulation"}));
  add_lens_options(cmd, o.fstop, o.focal_length, o.focus_distance);
  add_seed_and_threads(cmd, o.seed, o.threads,
                       "Random seed; each frame's seed is derived from it and the frame "
                       "number, so any subset of frames reproduces");
  add_shading_options(cmd, o.shading);
  add_environment_options(cmd, o.environment);
  cmd->add_option("--cache", o.cache,
                  "Radiance cache: none, octree or vdb (a fresh cache per frame unless "
                  "--persistent)")
      ->capture_default_str()
      ->check(CLI::IsMember(cache::radiance_cache_backends()))
      ->each([&o](const std::string&) { o.cache_given = true; });
  cmd->add_flag("--persistent", o.persistent,
                "Carry the cache across frames (the vdb backend unless --cache says otherwise)");
  add_cache_tuning_options(cmd, o.cache_settings);
  cmd->add_option("--cache-evict-after", o.evict_after,
                  "Evict cache samples no lookup used for this many frames (0: never)")
      ->capture_default_str()->check(CLI::Range(0, 1 << 30));
  cmd->add_option("--cache-memory", o.cache_memory_mb,
                  "Cap the cache at this many MB, evicting the least recently used first "
                  "(0: no cap)")
      ->capture_default_str()->check(CLI::Range(0.0, 1e9));
  cmd->add_option("--cache-in", o.cache_in, "Start from this cache file (.vdb)");
  cmd->add_option("--cache-out", o.cache_out, "Save the cache to this file (.vdb) at the end");
  cmd->add_option("--checkpoint", o.checkpoint,
                  "Checkpoint of the persistent cache, written after every frame so an "
                  "interrupted run resumes (default: .<pattern>.checkpoint.vdb beside the frames)");
  cmd->add_option("--checkpoint-journal", o.checkpoint_journal,
                  "After the first frame, append each frame's changes to a journal beside the "
                  "checkpoint until it reaches this many times the checkpoint's size, then "
                  "rewrite the checkpoint (0: rewrite it after every frame)")
      ->capture_default_str()->check(CLI::Range(0.0, 1e6));
  cmd->add_flag("--restart", o.restart,
                "Render every frame again, ignoring complete frames and the checkpoint");
  cmd->add_option("--stats-json", o.stats_json, "Write per-frame statistics as JSON to this file");
  cmd->add_flag("-q,--quiet", o.quiet, "Print only the first frame's path");
}

PreparedSequence prepare_sequence(const SequenceOptions& o) {
  PreparedSequence p;
  p.scene = std::make_unique<scene::Scene>(render::load_scene(o.scene_path, o.scene_index, o.limits));
  const scene::Scene& scene = *p.scene;
  p.camera = &scene.camera_or_first(o.camera);
  const scene::Camera& camera = *p.camera;
  p.accel = std::make_unique<scene::Accel>(scene);

  sequence::CameraPath& path = p.path;
  if (!o.path.empty()) {
    path = sequence::load_keyframe_path(o.path, camera);
  } else if (o.scene_path.empty()) {
    throw Error("the built-in scene has no animation: give a keyframe file with --path");
  } else {
    path = sequence::load_gltf_camera_path(o.scene_path, camera, o.animation);
  }
  p.fps = o.fps.value_or(path.fps.value_or(24.0));
  std::tie(p.first, p.last) = o.frames.empty() ? sequence::path_frame_range(path, p.fps)
                                        : sequence::parse_frame_range(o.frames);

  sequence::SequenceSettings& s = p.settings;
  render::RenderSettings& r = s.render;
  r.width = o.width;
  r.height = o.height > 0 ? o.height : render::height_for_width(camera, o.width);
  r.spp = o.spp;
  r.mode = render::parse_mode(o.mode);
  r.seed = o.seed;
  r.threads = o.threads;
  r.shading = o.shading;
  p.environment = render::resolve_environment(o.environment, scene, o.limits);
  r.shading.environment = p.environment.environment;
  r.cache = o.cache_settings;
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
  s.checkpoint_journal_ratio = o.checkpoint_journal;
  s.resume = !o.restart;
  s.validate();  // before planning frames (which may probe the scene for autofocus)

  p.frames = sequence::keep_every(
      sequence::plan_frames(scene, *p.accel, camera, path, p.fps, p.first, p.last,
                            {o.focal_length, o.fstop, o.focus_distance}),
      o.frame_step);
  return p;
}

}  // namespace dofcache::cli
