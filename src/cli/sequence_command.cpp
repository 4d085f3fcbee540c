#include <cstdio>
#include <filesystem>
#include <memory>

#include "commands.h"
#include "common_options.h"
#include "sequence_options.h"
#include "dofcache/sequence/sequence_request.h"

namespace dofcache::cli {
namespace {

struct SequenceOptions {
  request::RenderRequest request = request::default_request(request::Kind::Sequence);
  RequestFileOptions file;
};

int run_sequence(const request::RenderRequest& q, bool print_request) {
  sequence::PreparedSequence p = sequence::prepare_sequence(q);
  if (print_request) {
    std::printf("%s\n", request::resolved_json(p.resolved).dump(2).c_str());
    return 0;
  }
  const scene::Scene& scene = *p.scene;
  const sequence::SequenceSettings& s = p.settings;
  const render::RenderSettings& r = s.render;
  print_warnings(scene.warnings);
  sequence::SequenceRenderer renderer(scene, *p.accel, p.frames, s);
  print_environment_notices(p.resolved.environment);
  const bool cached = s.cache_mode != sequence::CacheMode::None;
  if (!q.quiet) {
    std::printf("scene    %s: %zu triangles, camera '%s'\n", scene.source.c_str(),
                scene.mesh.triangles.size(), p.camera->name.c_str());
    std::printf("path     %s, frames %d-%d at %g fps (%.3g-%.3g s)\n", p.path.source.c_str(),
                p.first, p.last, p.fps, p.first / p.fps, p.last / p.fps);
    std::printf("render   %dx%d %s, %d spp; cache %s%s\n", r.width, r.height,
                render::mode_name(r.mode), r.spp, sequence::cache_mode_name(s.cache_mode),
                cached ? (" (" + s.cache_backend + ")").c_str() : "");
    if (p.frames.front().autofocus)
      std::printf("notice   no focus distance given: autofocus on the image centre, per frame\n");
  }

  nlohmann::json rows = nlohmann::json::array();
  double reuse_sum = 0.0;
  int reuse_frames = 0;
  auto on_frame = [&](const sequence::FrameReport& f) {
    rows.push_back(sequence::frame_stats_json(f));
    const cache::FrameCacheStats& c = f.cache;
    if (!f.skipped && cached && f.index > 0) {
      reuse_sum += c.reuse_rate();
      ++reuse_frames;
    }
    if (q.quiet) return;
    if (f.skipped)
      std::printf("frame %4d  complete already  %s\n", f.frame, f.path.c_str());
    else if (!cached)
      std::printf("frame %4d  %6.2f s  wrote %s\n", f.frame, f.seconds(), f.path.c_str());
    else
      std::printf("frame %4d  %6.2f s  reuse %5.1f%%  hits %5.1f%%  +%zu -%zu samples  "
                  "%zu samples %.2f MB  wrote %s\n",
                  f.frame, f.seconds(), 100.0 * c.reuse_rate(), 100.0 * c.hit_rate(), c.inserted,
                  c.evicted_unused + c.evicted_memory, c.samples_at_end, c.memory_bytes / 1e6,
                  f.path.c_str());
  };
  auto notice = [&](const std::string& text) {
    if (!q.quiet) std::printf("notice   %s\n", text.c_str());
  };
  const sequence::SequenceSummary sum = renderer.run(on_frame, notice);
  if (!q.stats_json.empty())
    write_json_file(q.stats_json, sequence::sequence_stats_json(p, sum, rows));
  if (!q.quiet) {
    std::printf("sequence %d frames rendered, %d complete already, %.2f s", sum.rendered,
                sum.skipped, sum.seconds);
    if (reuse_frames > 0)
      std::printf(", mean reuse %.1f%% after the first frame", 100.0 * reuse_sum / reuse_frames);
    std::printf("\n");
  }
  std::printf("wrote    %s\n", std::filesystem::absolute(sequence::frame_path(q.out, p.first))
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
  add_sequence_options(cmd, o->request);
  add_request_file_options(cmd, o->file);
  return [o] {
    return run_sequence(
        apply_request_file(o->file, o->request, request::Kind::Sequence, add_sequence_options),
        o->file.print);
  };
}

}  // namespace dofcache::cli
