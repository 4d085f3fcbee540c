#pragma once
// Image files through OpenImageIO. The format follows the extension: .exr is linear half/float
// with any extra channels, .png is 8-bit sRGB colour. Writes are atomic: a temporary file in the
// same directory, renamed over the target only once complete.
#include <string>
#include <vector>

#include "dofcache/image/image.h"

namespace dofcache::image {

// Extra channels stored beside the colour in EXR files (ignored by PNG), e.g. {"Z"} for depth or
// {"N.X","N.Y","N.Z"} for normals. names.size() must equal image.channels().
struct NamedChannels {
  std::vector<std::string> names;
  Image image;
};

// Throws dofcache::Error (one line) if the extension is unsupported or the write fails; the target
// is then left untouched.
void write_image(const std::string& path, const Image& color,
                 const std::vector<NamedChannels>& extra = {});

// Reads the colour channels (RGB; alpha dropped) as linear float. PNG/JPEG are decoded from sRGB.
// Throws dofcache::Error if missing or unreadable.
Image read_image(const std::string& path);

// Reads the named channels of an EXR (e.g. {"Z"}); throws if any is absent.
Image read_channels(const std::string& path, const std::vector<std::string>& names);

// Writes `path` atomically: `write(tmp_path)` produces a complete file at tmp_path (same
// directory, same extension), then it is renamed to `path`. On any exception the temporary file
// is removed and the exception rethrown. Used by every writer in the project.
template <class WriteFn>
void write_atomically(const std::string& path, WriteFn&& write);
std::string temporary_path_for(const std::string& path);
void commit_temporary(const std::string& tmp_path, const std::string& path);
void discard_temporary(const std::string& tmp_path) noexcept;

template <class WriteFn>
void write_atomically(const std::string& path, WriteFn&& write) {
  std::string tmp = temporary_path_for(path);
  try {
    write(tmp);
    commit_temporary(tmp, path);
  } catch (...) {
    discard_temporary(tmp);
    throw;
  }
}

}  // namespace dofcache::image
