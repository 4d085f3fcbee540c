// Image files: the paths and images are checked here, every write made atomic (temporary file in
// the target's directory, then rename); the decoding, and the encoding of multi-part EXRs, is the
// codec module's (oiio_codec.cpp, loaded on first use: codec_module.h). PNG and EXR images are
// encoded here (png_encoder.cpp, exr_encoder.cpp).
#include "dofcache/image/image_io.h"

#include <algorithm>
#include <cctype>
#include <filesystem>

#include "codec_module.h"
#include "exr_encoder.h"
#include "dofcache/core/atomic_file.h"
#include "dofcache/core/error.h"

namespace dofcache::image {
namespace {

namespace fs = std::filesystem;

enum class Format { Exr, Png, Unsupported };

Format format_of(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == ".exr") return Format::Exr;
  if (ext == ".png") return Format::Png;
  return Format::Unsupported;
}

}  // namespace

bool is_exr_path(const std::string& path) { return format_of(path) == Format::Exr; }

namespace {

[[noreturn]] void fail_write(const std::string& path, const std::string& reason) {
  throw Error("cannot write '" + path + "': " + reason);
}

// The directory must exist before anything is attempted, so a typo gives a clear message.
void check_directory(const std::string& path) {
  fs::path dir = fs::path(path).parent_path();
  if (dir.empty()) return;
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    fail_write(path, "directory '" + dir.string() + "' does not exist");
}

// Throws the codec's error, if any.
void check(const std::string& error) {
  if (!error.empty()) throw Error(error);
}

}  // namespace

void check_output_path(const std::string& path) {
  if (format_of(path) == Format::Unsupported)
    fail_write(path, "unsupported image format (use .exr or .png)");
  check_directory(path);
}

void write_image(const std::string& path, const Image& color,
                 const std::vector<NamedChannels>& extra,
                 const std::map<std::string, std::string>& attributes) {
  check_output_path(path);
  if (color.empty()) fail_write(path, "empty image");
  if (color.channels() != 3)
    fail_write(path, "colour must have 3 channels (RGB), not " + std::to_string(color.channels()));
  // Encoded in memory first: a bad channel fails before the file is touched.
  const std::vector<unsigned char> bytes =
      format_of(path) == Format::Png ? encode_png(color)
                                     : exr_bytes(color, extra, "cannot write '" + path + "'", attributes);
  write_bytes_atomically(
      path, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

Image read_image(const std::string& path, std::uint64_t max_values) {
  Image out;
  check(codec::table().read_image(path, max_values, out));
  return out;
}

Image read_channels(const std::string& path, const std::vector<std::string>& names,
                    std::uint64_t max_values) {
  Image out;
  check(codec::table().read_channels(path, names, max_values, out));
  return out;
}

void write_multipart_exr(const std::string& path, const std::vector<ExrPart>& parts) {
  if (format_of(path) != Format::Exr) fail_write(path, "multi-part images must be .exr");
  check_directory(path);
  const codec::Table& codecs = codec::table();
  write_atomically(path, [&](const std::string& tmp) {
    check(codecs.write_multipart_exr(tmp, path, parts));
  });
}

std::vector<ExrPart> read_multipart_exr(const std::string& path, std::uint64_t max_values) {
  std::vector<ExrPart> parts;
  check(codec::table().read_multipart_exr(path, max_values, parts));
  return parts;
}

}  // namespace dofcache::image
