#include "dofcache/scene/default_scene.h"

namespace dofcache::scene {

const char* default_scene_name() { return "cornell_box"; }

Scene load_default_scene(const LoadOptions& options) {
  return load_gltf_from_memory(default_scene_gltf(),
                               std::string(default_scene_name()) + " (built in)", options);
}

}  // namespace dofcache::scene
