// Saved preview inputs (multi-part EXR through OpenImageIO/OpenEXR, then the dofcache parts,
// attributes and revealed-layer pixel lists).
#include "dofcache/preview/inputs_file.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dofcache;
  std::string path = fuzz::write_input("inputs.exr", data, size);
  // 4M floats: a file declaring more is refused before reading, which is what is exercised; the
  // default (2^30) would let single inputs take gigabytes.
  fuzz::expect_clean([&] { preview::load_preview_inputs(path, std::uint64_t{1} << 22); });
  return 0;
}
