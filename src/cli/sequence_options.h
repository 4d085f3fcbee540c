#pragma once
// The options of `dofcache sequence`, and turning them into a ready sequence (scene, frames,
// settings). Shared with `dofcache farm plan`, which parses the same options to validate them
// and to learn the frame range and image size before it writes a plan.
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "dofcache/render/renderer.h"
#include "dofcache/scene/accel.h"
#include "dofcache/scene/gltf_loader.h"
#include "dofcache/scene/scene.h"
#include "dofcache/sequence/camera_path.h"
#include "dofcache/sequence/sequence_renderer.h"

namespace dofcache::cli {

struct SequenceOptions {
  std::string scene_path, out = "frames/####.png", camera, mode = "drt", path, animation, frames;
  std::string stats_json;
  std::optional<double> fps;
  int scene_index = -1, width = 320, height = 0, spp = 16, threads = 0, frame_step = 1;
  scene::LoadLimits limits;
  std::uint64_t seed = 1;
  std::optional<double> fstop, focal_length, focus_distance;
  render::ShadingSettings shading;
  render::EnvironmentSettings environment;
  std::string cache = "none";
  bool persistent = false, cache_given = false, restart = false, quiet = false;
  render::CacheSettings cache_settings;
  int evict_after = 8;
  double cache_memory_mb = 0.0;
  double checkpoint_journal = 1.0;
  std::string cache_in, cache_out, checkpoint;
};

// Registers every `sequence` option (SCENE included) on `cmd`, writing into `o`.
void add_sequence_options(CLI::App* cmd, SequenceOptions& o);

// A sequence ready to render: the scene and its BVH, the path, the frames and the settings.
struct PreparedSequence {
  std::unique_ptr<scene::Scene> scene;
  const scene::Camera* camera = nullptr;
  std::unique_ptr<scene::Accel> accel;
  sequence::CameraPath path;
  double fps = 24.0;
  int first = 0, last = 0;  // the range asked for (frames may skip some with --frame-step)
  sequence::SequenceSettings settings;
  render::ResolvedEnvironment environment;  // also in settings.render.shading
  std::vector<sequence::FrameSpec> frames;
};

// Loads the scene and path and resolves every frame. Throws dofcache::Error on bad input.
PreparedSequence prepare_sequence(const SequenceOptions& o);

}  // namespace dofcache::cli
