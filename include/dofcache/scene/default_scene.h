#pragma once
// The built-in scene: scenes/cornell_box.gltf, embedded into the library at build time, so that
// `dofcache render` works without any file.
#include <string>

#include "dofcache/scene/gltf_loader.h"
#include "dofcache/scene/scene.h"

namespace dofcache::scene {

// The glTF JSON text of scenes/cornell_box.gltf (self-contained: base64 data-URI buffers).
const std::string& default_scene_gltf();

// "cornell_box".
const char* default_scene_name();

// load_gltf_from_memory(default_scene_gltf(), "cornell_box (built in)", options).
Scene load_default_scene(const LoadOptions& options = {});

}  // namespace dofcache::scene
