#include <cstdio>
#include <filesystem>
#include <memory>

#include "commands.h"
#include "common_options.h"
#include "sequence_options.h"
#include "dofcache/core/atomic_file.h"
#include "dofcache/core/stopwatch.h"
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
  print_warnings(scene.warnings);
  sequence::SequenceRenderer renderer(scene, *p.accel, p.frames, s);
  print_environment_notices(p.resolved.environment);
  const bool cached = s.cache_mode != sequence::CacheMode::None;
  if (!q.quiet) std::printf("%s", sequence::describe_start(p).c_str());

  nlohmann::json rows = nlohmann::json::array();
  auto on_frame = [&](const sequence::FrameReport& f) {
    rows.push_back(sequence::frame_stats_json(f));
    if (!q.quiet) std::printf("%s", sequence::describe_frame(f, cached).c_str());
  };
  auto notice = [&](const std::string& text) {
    if (!q.quiet) std::printf("notice   %s\n", text.c_str());
  };
  const bool temporal_only = p.resolved.request.sequence.temporal_only;
  const sequence::SequenceSummary sum =
      temporal_only ? sequence::SequenceSummary{} : renderer.run(on_frame, notice);
  if (!q.quiet && !temporal_only) std::printf("%s", sequence::describe_summary(sum).c_str());

  nlohmann::json temporal_rows;  // null: no temporal pass
  std::string first_path = sequence::frame_path(q.out, p.first);
  if (s.temporal_window > 0) {
    temporal_rows = nlohmann::json::array();
    const Stopwatch clock;
    sequence::run_temporal_pass(p.frames, s, [&](const sequence::TemporalFrameReport& f) {
      temporal_rows.push_back(sequence::temporal_stats_json(f));
      if (!q.quiet) std::printf("%s", sequence::describe_temporal_frame(f).c_str());
    });
    if (!q.quiet)
      std::printf("temporal %zu frames filtered, %.2f s\n", p.frames.size(), clock.seconds());
    first_path = sequence::frame_path(s.temporal_output, p.frames.front().number);
  }
  if (!q.stats_json.empty())
    write_bytes_atomically(
        q.stats_json, sequence::sequence_stats_json(p, sum, rows, temporal_rows).dump(2) + "\n");
  std::printf("wrote    %s\n",
              std::filesystem::absolute(first_path).lexically_normal().c_str());
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
