#pragma once
#include <cstdint>
#include <string>

#include "dofcache/scene/scene.h"

namespace dofcache::scene {

// What a file may make the loader allocate, checked against what the file declares before the
// memory is taken, so a hostile or broken file is refused in one line instead of exhausting the
// machine (docs/reliability.md). The defaults are far above the shipped scenes and ordinary
// production assets; the CLI raises them with --max-vertices, --max-triangles,
// --max-texture-pixels and --max-node-depth.
struct LoadLimits {
  // Summed over every mesh instance the scene's nodes place (a mesh placed twice counts twice).
  std::uint64_t max_vertices = 100'000'000;
  std::uint64_t max_triangles = 100'000'000;
  // Summed over the file's PNG/JPEG images, read from their headers before any is decoded.
  std::uint64_t max_texture_pixels = std::uint64_t{1} << 28;  // e.g. 4 textures of 8192^2
  // Nodes from a scene root to the deepest descendant (the loader recurses down the hierarchy).
  int max_node_depth = 1000;
};

struct LoadOptions {
  int scene_index = -1;  // -1: the file's default scene (or scene 0 if none is marked)
  LoadLimits limits;
};

// Loads a .gltf or .glb file. Every problem (missing file, invalid JSON, missing buffer,
// out-of-range accessor, non-finite positions, zero-area triangles, unsupported primitive mode,
// bad scene index, a node reached twice, a limit of `options.limits` exceeded) throws
// dofcache::Error with one line that names the file and the element.
// A scene without a camera gets one framing its bounds (Camera::synthesized = true).
Scene load_gltf(const std::string& path, const LoadOptions& options = {});

// The same from memory (for the embedded default scene); `name` is used in messages.
Scene load_gltf_from_memory(const std::string& data, const std::string& name,
                            const LoadOptions& options = {});

}  // namespace dofcache::scene
