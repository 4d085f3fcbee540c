// JSON keyframe files (camera paths): parsing, the tracks they build (step, linear and smooth
// interpolation) and evaluating the path over its time range.
#include <string>

#include "dofcache/sequence/camera_path.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dofcache;
  static const scene::Camera base;  // identity pose, as a scene without a camera gives
  const std::string text(reinterpret_cast<const char*>(data), size);
  fuzz::expect_clean([&] {
    sequence::CameraPath p = sequence::parse_keyframe_path(text, "fuzz.json", base);
    for (int i = 0; i <= 4; ++i) p.at(p.start_time + (p.end_time - p.start_time) * i / 4.0);
    sequence::path_frame_range(p, p.fps.value_or(24.0));
  });
  return 0;
}
