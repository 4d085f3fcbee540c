// glTF and .glb through the whole scene loader (tinygltf, accessors, node hierarchy, materials,
// images decoded by stb_image and converted to textures), then, where the file has a camera,
// the camera-path reader over its animations.
#include <string>

#include "dofcache/scene/gltf_loader.h"
#include "dofcache/sequence/camera_path.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dofcache;
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  // Smaller than the defaults so that a legitimately large input stays within the fuzzer's
  // memory limit; the limits themselves are what is being exercised.
  scene::LoadOptions options;
  options.limits.max_vertices = 1 << 20;
  options.limits.max_triangles = 1 << 20;
  options.limits.max_texture_pixels = 1 << 22;
  fuzz::expect_clean([&] {
    scene::Scene s = scene::load_gltf_from_memory(bytes, "fuzz.gltf", options);
    const scene::Camera& camera = s.cameras.front();
    if (camera.synthesized) return;
    std::string path = fuzz::write_input("scene.gltf", data, size);
    sequence::CameraPath p = sequence::load_gltf_camera_path(path, camera);
    for (double t : {p.start_time, 0.5 * (p.start_time + p.end_time), p.end_time}) p.at(t);
  });
  return 0;
}
