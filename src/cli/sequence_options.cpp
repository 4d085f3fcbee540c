#include "sequence_options.h"

#include "common_options.h"

namespace dofcache::cli {

void add_sequence_options(CLI::App* cmd, request::RenderRequest& r) {
  request::SequenceChoices& q = r.sequence;
  add_scene_options(cmd, r);
  cmd->add_option("--path", q.path,
                  "JSON keyframe file (docs/sequence.md); default: the glTF animation that moves "
                  "the camera");
  cmd->add_option("--animation", q.animation, "glTF animation to use, by name or index");
  cmd->add_option("--frames", q.frames, "Frames A-B (default: every frame of the path)");
  cmd->add_option("--frame-step", q.frame_step,
                  "Render every Nth frame of the range (and its last), e.g. keyframes that warm "
                  "a cache")
      ->capture_default_str()->check(CLI::Range(1, 1 << 30));
  cmd->add_option("--fps", q.fps, "Frames per second (default: the keyframe file's, else 24)")
      ->check(CLI::Range(1e-3, 1e4));
  cmd->add_option("-o,--out", r.out,
                  "Output pattern; a run of '#' becomes the zero-padded frame number. .png or "
                  ".exr (linear, with Z, N and id channels)")
      ->capture_default_str();
  add_size_options(cmd, r);
  cmd->add_option("--spp", r.spp, "Samples (lens rays) per pixel")->default_str("16")
      ->check(CLI::Range(1, 1 << 20));
  cmd->add_option_function<std::string>(
         "--mode", [&r](const std::string& name) { r.mode = request::parse_mode(name); },
         "drt, accumulation or pinhole")
      ->default_str(render::mode_name(r.mode.integrator))
      ->check(CLI::IsMember(render::mode_names()));
  add_lens_options(cmd, r.lens);
  add_real_lens_options(cmd, r.lens);
  add_seed_and_threads(cmd, r,
                       "Random seed; each frame's seed is derived from it and the frame "
                       "number, so any subset of frames reproduces");
  add_shading_options(cmd, r);
  add_denoise_option(cmd, r);
  add_environment_options(cmd, r.environment);
  add_cache_options(cmd, r,
                    "Radiance cache: none, octree or vdb (a fresh cache per frame unless "
                    "--persistent); auto: vdb with --persistent, else none");
  cmd->add_flag("--persistent", q.persistent,
                "Carry the cache across frames (the vdb backend unless --cache says otherwise)");
  cmd->add_option("--cache-evict-after", q.evict_after,
                  "Evict cache samples no lookup used for this many frames (0: never)")
      ->capture_default_str()->check(CLI::Range(0, 1 << 30));
  cmd->add_option("--cache-memory", q.cache_memory_mb,
                  "Cap the cache at this many MB, evicting the least recently used first "
                  "(0: no cap)")
      ->capture_default_str()->check(CLI::Range(0.0, 1e9));
  cmd->add_option("--cache-in", q.cache_in,
                  "Start from this cache file (.vdb); refused if made for another scene or "
                  "shading, or through a lens of another design (focus, f-number and focal "
                  "length may differ)");
  cmd->add_flag("--cache-any-lens", q.cache_any_lens,
                "Accept a --cache-in made through another lens (cached values do not depend on "
                "the lens; the reuse rule follows this render's)");
  cmd->add_option("--cache-out", q.cache_out, "Save the cache to this file (.vdb) at the end");
  cmd->add_option("--checkpoint", q.checkpoint,
                  "Checkpoint of the persistent cache, written after every frame so an "
                  "interrupted run resumes (default: .<pattern>.checkpoint.vdb beside the frames)");
  cmd->add_option("--checkpoint-journal", q.checkpoint_journal,
                  "After the first frame, append each frame's changes to a journal beside the "
                  "checkpoint until it reaches this many times the checkpoint's size, then "
                  "rewrite the checkpoint (0: rewrite it after every frame)")
      ->capture_default_str()->check(CLI::Range(0.0, 1e6));
  cmd->add_option("--temporal", q.temporal,
                  "After the frames exist, average each with this many frames on each side, "
                  "reprojected by depth and camera (docs/denoise.md); needs EXR frames, which "
                  "keep the raw render and the denoiser's layers (0: off)")
      ->capture_default_str()->check(CLI::Range(0, request::kMaxTemporalWindow));
  cmd->add_option("--temporal-output", q.temporal_output,
                  "Pattern of the temporally filtered frames, .png or .exr (default: --out with "
                  "'.temporal' before its extension)");
  cmd->add_flag("--temporal-only", q.temporal_only,
                "Filter frames written already, render none (the farm's last job)");
  cmd->add_flag("--restart", q.restart,
                "Render every frame again, ignoring complete frames and the checkpoint");
  cmd->add_option("--stats-json", r.stats_json, "Write per-frame statistics as JSON to this file");
  cmd->add_flag("-q,--quiet", r.quiet, "Print only the first frame's path");
}

}  // namespace dofcache::cli
