// Radiance cache files (.vdb through OpenVDB). The input is the OpenVDB part; the target seals
// it with a valid dofcache trailer, as a forged file would be, so that the mutations reach the
// OpenVDB reader and the checks after it instead of stopping at the checksum.
#include <algorithm>
#include <cstdlib>
#include <new>
#include <string>

#include "dofcache/sequence/cache_file.h"
#include "fuzz_common.h"

// OpenVDB sizes some buffers from the stream before reading them (bloscFromStream, for one). In
// a normal build a forged size makes that `new` throw std::bad_alloc, which read_cache_file
// refuses in one line like any other damage; ASan's operator new aborts instead. So this target
// allocates through malloc, which ASan lets fail (allocator_may_return_null), and throws as the
// normal build does. (libFuzzer's -rss_limit_mb still catches real memory growth.)
extern "C" const char* __asan_default_options() {
  return "allocator_may_return_null=1:max_allocation_size_mb=2048";
}
// Every form, so that no allocation mixes this allocator with ASan's operator new.
void* operator new(std::size_t n, const std::nothrow_t&) noexcept { return std::malloc(n ? n : 1); }
void* operator new[](std::size_t n, const std::nothrow_t& t) noexcept { return operator new(n, t); }
void* operator new(std::size_t n) {
  if (void* p = operator new(n, std::nothrow)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n) { return operator new(n); }
void* operator new(std::size_t n, std::align_val_t a, const std::nothrow_t&) noexcept {
  void* p = nullptr;
  return posix_memalign(&p, std::max(static_cast<std::size_t>(a), sizeof(void*)), n ? n : 1) == 0
             ? p
             : nullptr;
}
void* operator new[](std::size_t n, std::align_val_t a, const std::nothrow_t& t) noexcept {
  return operator new(n, a, t);
}
void* operator new(std::size_t n, std::align_val_t a) {
  if (void* p = operator new(n, a, std::nothrow)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n, std::align_val_t a) { return operator new(n, a); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dofcache;
  std::string path = fuzz::write_input("cache.vdb", data, size);
  fuzz::expect_clean([&] {
    sequence::append_cache_file_trailer(path);
    sequence::read_cache_file(path);
  });
  return 0;
}
