// Cache traces (the binary record of a render's cache lookups and inserts).
#include "dofcache/cache/trace.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dofcache;
  std::string path = fuzz::write_input("trace.bin", data, size);
  fuzz::expect_clean([&] { cache::read_trace(path); });
  return 0;
}
