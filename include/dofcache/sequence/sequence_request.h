#pragma once
// A sequence request (request::Kind::Sequence) made ready to render: the scene and its BVH, the
// camera path, the frames and the sequence settings, resolved by request::resolve like every other
// front end's request. `dofcache sequence`, `dofcache farm plan` and the farm's jobs use it.
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "dofcache/request/render_request.h"
#include "dofcache/request/resolve.h"
#include "dofcache/scene/accel.h"
#include "dofcache/scene/scene.h"
#include "dofcache/sequence/camera_path.h"
#include "dofcache/sequence/sequence_renderer.h"
#include "dofcache/sequence/temporal_pass.h"

namespace dofcache::sequence {

struct PreparedSequence {
  std::unique_ptr<scene::Scene> scene;
  const scene::Camera* camera = nullptr;
  std::unique_ptr<scene::Accel> accel;
  request::ResolvedRequest resolved;
  CameraPath path;
  double fps = 24.0;
  int first = 0, last = 0;  // the range asked for (frames may skip some with frame_step)
  SequenceSettings settings;
  std::vector<FrameSpec> frames;
};

// Loads the scene and path, resolves the request and every frame. Throws dofcache::Error on bad
// input (including a request of another kind).
PreparedSequence prepare_sequence(const request::RenderRequest& request);

// The sequence in words, as `sequence` prints it: the scene, the path and its frames, the render
// and cache, and the autofocus notice. Lines end with newlines.
std::string describe_start(const PreparedSequence& sequence);
// One frame's line: its time and file, with the cache's reuse when `cached`.
std::string describe_frame(const FrameReport& frame, bool cached);
// The run's last line: frames rendered and complete already, time, the mean reuse.
std::string describe_summary(const SequenceSummary& summary);
// One frame's line of the temporal pass.
std::string describe_temporal_frame(const TemporalFrameReport& frame);

// Statistics as `sequence --stats-json` writes them: one row per frame, and the whole run, with
// the temporal pass's rows (null: no pass).
nlohmann::json frame_stats_json(const FrameReport& frame);
nlohmann::json temporal_stats_json(const TemporalFrameReport& frame);
nlohmann::json sequence_stats_json(const PreparedSequence& sequence, const SequenceSummary& summary,
                                   const nlohmann::json& rows,
                                   const nlohmann::json& temporal_rows = nullptr);

}  // namespace dofcache::sequence
