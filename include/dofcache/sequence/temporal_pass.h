#pragma once
// The temporal filter (denoise/temporal_filter.h) over a camera path's frames once they are
// written: each frame read back from its EXR (the denoised colour, the centre depth and normal,
// the lens samples' depth and the raw variance) and averaged with the `temporal_window` frames on
// each side of it in the sequence, reprojected by depth and the frames' cameras, then written to
// the `temporal_output` pattern (PNG: the filtered colour; EXR: with Z, N and id beside it).
//
// It reads only files, so resume, frame subsets and farm chunks render exactly as without it; the
// farm runs it as one last job over the whole path. A frame at either end of the sequence has
// fewer neighbours on that side. Every run filters every frame again: it takes a small fraction
// of a frame's render.
#include <functional>
#include <string>
#include <vector>

#include "dofcache/sequence/camera_path.h"
#include "dofcache/sequence/sequence_renderer.h"

namespace dofcache::sequence {

struct TemporalFrameReport {
  int frame = 0;
  int index = 0, count = 0;  // position in the sequence
  int neighbours = 0;        // frames averaged with it
  std::string path;          // the filtered frame
  double seconds = 0.0;      // reading, filtering and writing
};

// Filters every frame of `frames` (in increasing frame number, as rendered with `settings`;
// settings.temporal_window > 0). Throws dofcache::Error (one line) if a frame is missing or was
// written without the denoiser's layers.
void run_temporal_pass(const std::vector<FrameSpec>& frames, const SequenceSettings& settings,
                       const std::function<void(const TemporalFrameReport&)>& on_frame = {});

}  // namespace dofcache::sequence
