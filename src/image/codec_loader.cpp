// Finds and loads the image codec module (codec_module.h): next to the running executable (an
// installed or copied program), else where the build put it (the build tree's tests and tools).
#include <dlfcn.h>

#include <chrono>
#include <filesystem>
#include <future>
#include <mutex>

#include "codec_module.h"
#include "dofcache/core/error.h"

namespace dofcache::image {
namespace codec {
namespace {

namespace fs = std::filesystem;

constexpr const char* kModuleFile = "libdofcache_image_codec.so";

struct Loaded {
  const Table* table = nullptr;
  std::string error;
};

std::vector<std::string> candidates() {
  std::vector<std::string> paths;
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) paths.push_back((exe.parent_path() / kModuleFile).string());
  paths.push_back(DOFCACHE_IMAGE_CODEC_PATH);
  return paths;
}

Loaded load() {
  std::string why = "not found";
  for (const std::string& path : candidates()) {
    std::error_code ec;
    if (!fs::exists(path, ec)) continue;
    // Kept loaded for the life of the process: OpenImageIO has global state and threads.
    void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!handle) {
      const char* e = dlerror();
      why = e ? e : "dlopen failed";
      continue;
    }
    auto entry = reinterpret_cast<EntryPoint>(dlsym(handle, kEntryPoint));
    const Table* t = entry ? entry() : nullptr;
    if (!t || t->abi_version != kAbiVersion) {
      why = path + " is from another build of dofcache";
      continue;
    }
    return {t, {}};
  }
  return {nullptr, one_line("cannot load the image codec module " + std::string(kModuleFile) +
                            " (it reads and writes every image file): " + why)};
}

std::once_flag started;
std::shared_future<Loaded> loaded;

void start(std::launch policy) {
  std::call_once(started, [policy] { loaded = std::async(policy, load).share(); });
}

}  // namespace

const Table& table() {
  start(std::launch::deferred);  // no-op after preload_image_codecs()
  const Loaded& l = loaded.get();
  if (!l.table) throw Error(l.error);
  return *l.table;
}

}  // namespace codec

void preload_image_codecs() { codec::start(std::launch::async); }

void finish_loading_image_codecs() {
  // Only a started background load: a deferred one would load here.
  if (codec::loaded.valid() &&
      codec::loaded.wait_for(std::chrono::seconds(0)) != std::future_status::deferred)
    codec::loaded.wait();
}

}  // namespace dofcache::image
