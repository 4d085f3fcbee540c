#pragma once
// The boundary between the image library and its codec module (oiio_codec.cpp), the one place that
// uses OpenImageIO. OpenImageIO as packaged links about 260 shared libraries (video, camera-raw,
// DICOM, HEIF and more codecs) whose loading and symbol binding cost every process about a third of
// a CPU-second at start, before main; most runs of dofcache need them only to write one image at
// the end, and the viewer's first preview not at all. So the codec is a module loaded on first use
// (or ahead of time by preload_image_codecs(), in the background) rather than linked.
//
// Both sides are built together by the same compiler, so the table passes C++ types; exceptions do
// not cross it: every function returns an empty string on success, else the one-line error.
#include <cstdint>
#include <string>
#include <vector>

#include "dofcache/image/image.h"
#include "dofcache/image/image_io.h"

#define DOFCACHE_CODEC_EXPORT __attribute__((visibility("default")))

namespace dofcache::image::codec {

constexpr int kAbiVersion = 4;

// `file` is what a writer writes (the temporary file of an atomic write), `path` the name its
// messages give. Inputs are checked by the caller as image_io.h describes; readers do all checks.
struct Table {
  int abi_version;
  std::string (*read_image)(const std::string& path, std::uint64_t max_values, Image& out);
  std::string (*read_channels)(const std::string& path, const std::vector<std::string>& names,
                               std::uint64_t max_values, Image& out);
  std::string (*write_multipart_exr)(const std::string& file, const std::string& path,
                                     const std::vector<ExrPart>& parts);
  std::string (*read_multipart_exr)(const std::string& path, std::uint64_t max_values,
                                    std::vector<ExrPart>& out);
};

// The module's one exported symbol.
constexpr const char* kEntryPoint = "dofcache_image_codec";
using EntryPoint = const Table* (*)();

// The loaded table; the first call loads the module (waiting for a preload in progress). Throws
// dofcache::Error (one line) if it cannot be found or loaded.
const Table& table();

}  // namespace dofcache::image::codec
