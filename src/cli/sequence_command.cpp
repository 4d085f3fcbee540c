#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>

#include "commands.h"
#include "common_options.h"
#include "sequence_options.h"
#include "dofcache/core/error.h"
#include "dofcache/render/renderer.h"
#include "dofcache/render/setup.h"
#include "dofcache/scene/accel.h"
#include "dofcache/sequence/camera_path.h"
#include "dofcache/sequence/sequence_renderer.h"

namespace dofcache::cli {
namespace {


int run_sequence(const SequenceOptions& o) {
  PreparedSequence p = prepare_sequence(o);
  const scene::Scene& scene = *p.scene;
  const scene::Camera& camera = *p.camera;
  const sequence::CameraPath& path = p.path;
  const double fps = p.fps;
  const int first = p.first, last = p.last;
  const sequence::SequenceSettings& s = p.settings;
  const render::RenderSettings& r = s.render;
  const std::vector<sequence::FrameSpec>& frames = p.frames;
  for (const std::string& w : scene.warnings) std::fprintf(stderr, "dofcache: warning: %s\n", w.c_str());
  sequence::SequenceRenderer renderer(scene, *p.accel, frames, s);
  print_environment_notices(p.environment);

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
                    {"cache_memory_bytes", c.memory_bytes},
                    {"checkpoint_bytes", f.checkpoint_bytes}, {"checkpoint_full", f.checkpoint_full},
                    {"checkpoint_seconds", f.checkpoint_seconds},
                    {"checkpoint_cpu_seconds", f.checkpoint_cpu_seconds}});
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
        {"cache", cache_settings_json(s.cache_backend, r)},
        {"environment", environment_json(o.environment, p.environment)},
        {"rendered", sum.rendered}, {"skipped", sum.skipped},
        {"resumed_after", sum.resumed_after}, {"seconds", sum.seconds}, {"per_frame", rows}};
    j["cache"].update({{"mode", sequence::cache_mode_name(s.cache_mode)},
                       {"evict_after", s.evict_after}, {"memory_mb", s.cache_memory_mb}});
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
  add_sequence_options(cmd, *o);
  return [o] { return run_sequence(*o); };
}

}  // namespace dofcache::cli
