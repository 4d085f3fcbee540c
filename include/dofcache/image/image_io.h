#pragma once
// Image files: PNG and single-part EXR written with libpng and OpenEXR, everything else through
// OpenImageIO (loaded on first use: src/image/codec_module.h). The format follows the extension (case-insensitive): .exr is
// linear 32-bit float, colour and extra channels alike (so every value round-trips exactly; ZIP
// compression keeps the files reasonable), .png is 8-bit sRGB colour. Writes are atomic
// (dofcache/core/atomic_file.h): a temporary file in the same directory, renamed over the target
// only once complete.
#include <cmath>
#include <cstdint>
#include <map>
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
// is then left untouched. An EXR also keeps `attributes` in its header, as "dofcache:<key>"
// strings (read_multipart_exr gives them back); a PNG has no place for them.
void write_image(const std::string& path, const Image& color,
                 const std::vector<NamedChannels>& extra = {},
                 const std::map<std::string, std::string>& attributes = {});

// `color` (RGB linear) as the bytes of an 8-bit sRGB PNG file, in memory (what write_image
// writes for .png), e.g. for an HTTP response. Throws dofcache::Error if encoding fails.
std::vector<unsigned char> encode_png(const Image& color);
// The same as a linear 32-bit float RGB EXR file (what write_image writes for .exr, without
// extra channels).
std::vector<unsigned char> encode_exr(const Image& color);

// Whether write_image writes `path` as EXR (extension .exr in any case): float colour with its
// extra channels, where a PNG keeps 8-bit colour only.
bool is_exr_path(const std::string& path);

// Throws the error write_image would give for an unsupported extension or a missing directory,
// so callers can refuse a bad output path before spending time on a render.
void check_output_path(const std::string& path);

// The most values (pixels x channels, all parts of a file together) a read may allocate: checked
// against the file's headers before any pixel is read, so a small file declaring a huge image is
// refused (docs/reliability.md). 2^30 floats are 4 GiB, e.g. RGBA at 16384x16384.
constexpr std::uint64_t kMaxImageValues = std::uint64_t{1} << 30;

// Reads the colour channels (RGB; alpha dropped) as linear float. PNG/JPEG are decoded from sRGB.
// Throws dofcache::Error if missing, unreadable or larger than `max_values`.
Image read_image(const std::string& path, std::uint64_t max_values = kMaxImageValues);

// Reads the named channels of an EXR (e.g. {"Z"}); throws if any is absent.
Image read_channels(const std::string& path, const std::vector<std::string>& names,
                    std::uint64_t max_values = kMaxImageValues);

// One part of a multi-part EXR: a named layer (e.g. "color", "depth", "ids") with its own channels
// and string metadata. channel_names.size() must equal image.channels(); all parts of a file may
// have different sizes. Every channel is stored as 32-bit float, so integer data such as object
// ids survives exactly as long as it is below 2^24 (16777216).
struct ExrPart {
  std::string name;
  std::vector<std::string> channel_names;
  Image image;
  std::map<std::string, std::string> attributes;
};

// Writes all parts into one multi-part EXR, atomically. Part names must be non-empty and unique,
// channel names unique within a part. The attributes are stored in the part headers as strings
// named "dofcache:<key>", which keeps them apart from the standard EXR attributes. Throws
// dofcache::Error (one line) on invalid input or a failed write; the target is then untouched.
void write_multipart_exr(const std::string& path, const std::vector<ExrPart>& parts);

// Reads every part of an EXR (a single-part file gives one part) with its channels in the order
// they were written and the "dofcache:" attributes (prefix stripped). Throws dofcache::Error if
// missing, unreadable, or if its parts together hold more than `max_values`.
std::vector<ExrPart> read_multipart_exr(const std::string& path,
                                        std::uint64_t max_values = kMaxImageValues);

// Loads the image codecs in the background now, so that the first read or write does not wait
// for them (a third of a CPU-second): for programs that will surely need them. Optional.
void preload_image_codecs();

// Waits until a background load that preload_image_codecs() started has finished (no-op
// otherwise). A program that preloads calls it before it exits: the process must not exit while
// the loader thread is inside dlopen, running the constructors of OpenImageIO's libraries, whose
// objects would be torn down half-made (LeakSanitizer saw them leak).
void finish_loading_image_codecs();

// The sRGB transfer functions (IEC 61966-2-1): encode = linear -> display, decode the inverse.
// Inline: the codec module (which cannot see the program's symbols) uses them too.
inline float linear_to_srgb(float linear) {
  if (!(linear > 0.0f)) return 0.0f;  // also NaN
  if (linear >= 1.0f) return 1.0f;
  if (linear <= 0.0031308f) return 12.92f * linear;
  return 1.055f * std::pow(linear, 1.0f / 2.4f) - 0.055f;
}
inline float srgb_to_linear(float encoded) {
  if (encoded <= 0.04045f) return encoded / 12.92f;
  return std::pow((encoded + 0.055f) / 1.055f, 2.4f);
}

}  // namespace dofcache::image
