// Lens prescription tables (--lens-file): the reader and the paraxial trace of what it accepts.
#include "dofcache/lens/lens_system.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dofcache;
  const std::string text(reinterpret_cast<const char*>(data), size);
  fuzz::expect_clean([&] {
    const lens::LensSystem s = lens::LensSystem::parse(text, "fuzz.dat");
    (void)s.effective_focal_length();
    (void)s.back_focal_distance();
  });
  return 0;
}
