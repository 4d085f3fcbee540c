#pragma once
#include <string>

#include "dofcache/scene/scene.h"

namespace dofcache::scene {

struct LoadOptions {
  int scene_index = -1;  // -1: the file's default scene (or scene 0 if none is marked)
};

// Loads a .gltf or .glb file. Every problem (missing file, invalid JSON, missing buffer,
// out-of-range accessor, non-finite positions, zero-area triangles, unsupported primitive mode,
// bad scene index) throws dofcache::Error with one line that names the file and the element.
// A scene without a camera gets one framing its bounds (Camera::synthesized = true).
Scene load_gltf(const std::string& path, const LoadOptions& options = {});

// The same from memory (for the embedded default scene); `name` is used in messages.
Scene load_gltf_from_memory(const std::string& data, const std::string& name,
                            const LoadOptions& options = {});

}  // namespace dofcache::scene
