#pragma once
// Shared by the libFuzzer targets (docs/reliability.md). A target feeds its input to one reader;
// the only acceptable way to refuse input is dofcache::Error with a one-line message. Anything
// else (a crash, a sanitizer report, another exception escaping, a multi-line message) aborts,
// which libFuzzer records as a finding with the input that caused it.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "dofcache/core/error.h"

namespace dofcache::fuzz {

// A scratch directory of this process (removed at exit), for readers that take a path. In memory
// (/dev/shm) where there is one: each input is a file written and read again, and on a disk
// (ext4) rewriting a file flushes it to the device, a quarter of the time per input.
inline const std::filesystem::path& scratch_dir() {
  static const std::filesystem::path dir = [] {
    std::error_code ec;
    const std::filesystem::path base = std::filesystem::is_directory("/dev/shm", ec)
                                           ? std::filesystem::path("/dev/shm")
                                           : std::filesystem::temp_directory_path();
    auto d = base / ("dofcache-fuzz-" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    std::atexit([] {
      std::error_code ec;
      std::filesystem::remove_all(scratch_dir(), ec);
    });
    return d;
  }();
  return dir;
}

// Writes `size` bytes (plus `suffix`) to `name` in the scratch directory; returns its path.
inline std::string write_input(const std::string& name, const std::uint8_t* data, std::size_t size,
                               const std::string& suffix = "") {
  std::string path = (scratch_dir() / name).string();
  std::error_code ec;
  std::filesystem::remove(path, ec);  // a new file: ext4 flushes a truncated one when it closes
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  out.write(suffix.data(), static_cast<std::streamsize>(suffix.size()));
  out.close();
  if (!out) {
    std::fprintf(stderr, "fuzz: cannot write %s\n", path.c_str());
    std::abort();
  }
  return path;
}

// Runs `read`; a dofcache::Error is the expected refusal, but its message must be one line.
template <class F>
void expect_clean(F&& read) {
  try {
    read();
  } catch (const Error& e) {
    std::string message = e.what();
    if (message.empty() || message.find('\n') != std::string::npos) {
      std::fprintf(stderr, "fuzz: error message is not one line: [%s]\n", message.c_str());
      std::abort();
    }
  }
}

}  // namespace dofcache::fuzz
