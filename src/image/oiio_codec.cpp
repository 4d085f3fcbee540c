// The image codec module: every use of OpenImageIO, built as a shared module that the image
// library loads on first use (codec_module.h says why): every image read (EXR with named channels
// and parts, PNG, and what else OpenImageIO reads) and the multi-part EXR writer. The writer writes
// the file it is given; image_io.cpp makes the write atomic and checks paths first.
#include "codec_module.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <set>

#include "dofcache/core/error.h"

namespace dofcache::image::oiio {
namespace {

namespace fs = std::filesystem;
using OIIO::ImageInput;
using OIIO::ImageOutput;
using OIIO::ImageSpec;
using OIIO::TypeDesc;

// User metadata in EXR headers lives under this prefix; the channel order of a part (which
// OpenEXR itself stores sorted by name) under the internal key.
constexpr const char* kAttributePrefix = "dofcache:";
constexpr const char* kChannelOrderKey = "dofcacheInternal:channelOrder";

// OpenImageIO messages may span lines; our errors are one line.
std::string reason_line(const std::string& message) {
  std::string line = dofcache::one_line(message);
  return line.empty() ? std::string("unknown error") : line;
}

[[noreturn]] void fail_write(const std::string& path, const std::string& reason) {
  throw Error("cannot write '" + path + "': " + reason_line(reason));
}
[[noreturn]] void fail_read(const std::string& path, const std::string& reason) {
  throw Error("cannot read '" + path + "': " + reason_line(reason));
}

std::string join(const std::vector<std::string>& names, const char* separator) {
  std::string out;
  for (size_t i = 0; i < names.size(); ++i) out += (i ? separator : "") + names[i];
  return out;
}

std::vector<std::string> split_lines(const std::string& text) {
  std::vector<std::string> out;
  size_t start = 0;
  while (start <= text.size()) {
    size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    out.push_back(text.substr(start, end - start));
    start = end + 1;
  }
  return out;
}

// A float EXR spec for `names` (all channels 32-bit float, ZIP: lossless and compact).
ImageSpec exr_spec(int width, int height, const std::vector<std::string>& names) {
  ImageSpec spec(width, height, static_cast<int>(names.size()), TypeDesc::FLOAT);
  spec.channelnames = names;
  // The constructor guessed RGBA roles from the channel count; set them from the names instead.
  auto index_of = [&](const char* name) {
    auto it = std::find(names.begin(), names.end(), name);
    return it == names.end() ? -1 : static_cast<int>(it - names.begin());
  };
  spec.alpha_channel = index_of("A");
  spec.z_channel = index_of("Z");
  spec.attribute("compression", "zip");
  return spec;
}

void check_unique(const std::string& path, const std::vector<std::string>& names,
                  const std::string& what) {
  std::set<std::string> seen;
  for (const std::string& n : names) {
    if (n.empty()) fail_write(path, "empty " + what + " name");
    if (!seen.insert(n).second) fail_write(path, "duplicate " + what + " '" + n + "'");
  }
}

std::unique_ptr<ImageOutput> create_output(const std::string& tmp, const std::string& path) {
  auto out = ImageOutput::create(tmp);
  if (!out) fail_write(path, OIIO::geterror());
  return out;
}

// An open image file, its first subimage's spec already read.
struct OpenedInput {
  std::unique_ptr<ImageInput> in;
  ImageSpec spec;
};

// OpenEXR sizes what it allocates for a header from the header itself: an attribute's declared
// size (a 2.7 KB file declaring a 1.9 GB string made it allocate and fill 1.9 GB), the data
// window (its line offset table) and, for its decompressor, a block of scanlines (or a tile) of
// every channel: a 2.7 KB file of one 2-million-pixel scanline of 6 channels, ZIP-compressed (16
// lines a block), made it allocate 805 MB. So the headers of an EXR are walked first, every
// attribute checked against the bytes the file has, every channel's pixel type, and each part's
// values (pixels, or the pixels of a compression block or tile if more, times channels) against
// `max_values`.
// The size of OpenEXR's attribute types of fixed size (Imf*Attribute.cpp), -1 for the others.
int exr_attribute_size(const std::string& type) {
  static const std::map<std::string, int> sizes = {
      {"box2i", 16}, {"box2f", 16},  {"chromaticities", 32}, {"compression", 1},
      {"deepImageState", 1},         {"double", 8},          {"envmap", 1},
      {"float", 4},  {"int", 4},     {"keycode", 28},        {"lineOrder", 1},
      {"m33f", 36},  {"m33d", 72},   {"m44f", 64},           {"m44d", 128},
      {"rational", 8}, {"tiledesc", 9}, {"timecode", 8},     {"v2i", 8},
      {"v2f", 8},    {"v2d", 16},    {"v3i", 12},            {"v3f", 12},
      {"v3d", 24}};
  auto it = sizes.find(type);
  return it == sizes.end() ? -1 : it->second;
}

void check_exr_headers(const std::string& path, std::uint64_t max_values) {
  std::error_code ec;
  const std::uint64_t file_size = fs::file_size(path, ec);
  std::ifstream in(path, std::ios::binary);
  char magic[8];
  if (ec || !in.read(magic, 8) || std::memcmp(magic, "\x76\x2f\x31\x01", 4) != 0) return;
  const bool multipart = (static_cast<unsigned char>(magic[5]) & 0x10) != 0;
  auto damaged = [&](const std::string& what) {
    fail_read(path, "damaged EXR header (" + what + ")");
  };
  auto name = [&] {  // null-terminated; OpenEXR's longest names are 255 bytes
    std::string n;
    if (!std::getline(in, n, '\0') || n.size() > 255) damaged("unterminated name");
    return n;
  };
  for (int part = 0;; ++part) {
    if (part > 0 && in.peek() == 0) break;  // the end of a multi-part file's headers
    std::int64_t w = 0, h = 0, tile_w = 0, tile_h = 0;
    std::uint64_t channels = 0;
    int compression = 0;
    for (std::string attribute = name(); !attribute.empty(); attribute = name()) {
      const std::string type = name();
      std::int32_t size;
      if (!in.read(reinterpret_cast<char*>(&size), 4)) damaged("truncated");
      const auto offset = static_cast<std::uint64_t>(in.tellg());
      if (size < 0 || static_cast<std::uint64_t>(size) > file_size - offset)
        damaged("attribute '" + attribute + "' claims " + std::to_string(size) +
                " bytes, the file has " + std::to_string(file_size));
      // OpenEXR reads an attribute of a fixed-size type by its type, whatever size it claims:
      // a float claiming 2 bytes put OpenEXR 2 bytes past this walk, where it read a 1.7 GB
      // attribute (found by fuzzing preview inputs).
      const int fixed = exr_attribute_size(type);
      if (fixed >= 0 && size != fixed)
        damaged("attribute '" + attribute + "' of type " + type + " claims " +
                std::to_string(size) + " bytes, not " + std::to_string(fixed));
      if (attribute == "dataWindow" && size == 16) {
        std::int32_t box[4];
        in.read(reinterpret_cast<char*>(box), 16);
        w = std::int64_t(box[2]) - box[0] + 1;
        h = std::int64_t(box[3]) - box[1] + 1;
        if (w <= 0 || h <= 0) damaged("empty data window");
      } else if (attribute == "compression" && size == 1) {
        compression = in.get();
      } else if (attribute == "tiles" && size == 9) {
        std::uint32_t tile[2];
        in.read(reinterpret_cast<char*>(tile), 8);
        in.seekg(1, std::ios::cur);
        tile_w = tile[0];
        tile_h = tile[1];
      } else if (type == "chlist" || type == "stringvector" || type == "preview") {
        // OpenEXR reads these by their content, not by the size they claim: the content must
        // end where the size says (a channel list without its terminator there made OpenEXR
        // read on into a 1.9 GB attribute; found by fuzzing preview inputs).
        if (size > (1 << 20)) damaged("attribute '" + attribute + "' of " + std::to_string(size) + " bytes");
        std::string v(static_cast<std::size_t>(size), '\0');
        in.read(v.data(), size);
        if (type == "chlist") {
          // Channels (name, pixel type, linearity, 3 reserved bytes, x and y sampling), then an
          // empty name. OpenImageIO aborts (an assertion) on a pixel type other than UINT, HALF
          // and FLOAT.
          channels = 0;
          std::size_t c = 0;
          for (; c < v.size() && v[c] != '\0'; ++channels) {
            std::size_t end = v.find('\0', c);
            if (end == std::string::npos || end + 17 > v.size()) damaged("channel list");
            std::int32_t pixel_type;
            std::memcpy(&pixel_type, v.data() + end + 1, 4);
            if (pixel_type < 0 || pixel_type > 2)
              damaged("channel '" + v.substr(c, end - c) + "' has unknown pixel type " +
                      std::to_string(pixel_type));
            c = end + 17;
          }
          if (c + 1 != v.size()) damaged("channel list not ending where its size says");
        } else if (type == "stringvector") {  // strings, each an int32 length and its bytes
          for (std::size_t c = 0; c < v.size();) {
            std::int32_t n = -1;
            if (c + 4 <= v.size()) std::memcpy(&n, v.data() + c, 4);
            if (n < 0 || static_cast<std::uint64_t>(n) > v.size() - c - 4)
              damaged("string vector '" + attribute + "'");
            c += 4 + static_cast<std::size_t>(n);
          }
        } else {  // preview: u32 width and height, then RGBA bytes
          std::uint32_t wh[2] = {0, 0};
          if (v.size() >= 8) std::memcpy(wh, v.data(), 8);
          if (v.size() < 8 || std::uint64_t(wh[0]) * wh[1] * 4 != v.size() - 8)
            damaged("preview image");
        }
      } else {
        in.seekg(size, std::ios::cur);
      }
    }
    const std::uint64_t pixels = std::uint64_t(w) * std::uint64_t(h);
    if (pixels > max_values)
      fail_read(path, std::to_string(w) + "x" + std::to_string(h) +
                          " pixels exceed the image size limit (" + std::to_string(max_values) +
                          " values in all)");
    // Scanlines a compressed block holds (OpenEXR's Compression enum, 0-9): NONE, RLE and ZIPS
    // one, ZIP and PXR24 16, PIZ, B44, B44A and DWAA 32, DWAB 256. The decompressor's buffer
    // holds a block (or a tile) of every channel however few lines the image has; small blocks
    // (up to 2^20 values, 4 MB) are allowed whatever the limit.
    static constexpr std::int64_t kBlockLines[10] = {1, 1, 1, 16, 32, 16, 32, 32, 32, 256};
    const std::int64_t lines = compression >= 0 && compression < 10 ? kBlockLines[compression] : 1;
    const std::uint64_t block = tile_w > 0 ? std::uint64_t(tile_w) * std::uint64_t(tile_h)
                                           : std::uint64_t(w) * std::uint64_t(lines);
    const std::uint64_t most = std::max(pixels, block);
    const std::uint64_t n = std::max<std::uint64_t>(channels, 1);
    if (most > max_values / n && (pixels > max_values / n || most > (std::uint64_t{1} << 20) / n))
      fail_read(path, std::to_string(w) + "x" + std::to_string(h) + " pixels of " +
                          std::to_string(channels) + " channels" +
                          (block > pixels ? " (decompressed " + std::to_string(block) +
                                                " pixels at a time)"
                                          : std::string()) +
                          " exceed the image size limit (" + std::to_string(max_values) +
                          " values in all)");
    if (!multipart) break;
  }
}

// Opens `path` with the reader of `format` (an OpenImageIO format name) if one is given, else
// with the reader OpenImageIO finds for the file.
OpenedInput open_input(const std::string& path, std::uint64_t max_values,
                       const char* format = nullptr) {
  std::error_code ec;
  if (!fs::exists(path, ec)) fail_read(path, "no such file");
  if (fs::is_directory(path, ec)) fail_read(path, "is a directory");
  check_exr_headers(path, max_values);
  // Keep straight (unassociated) colour: alpha is dropped, so premultiplying would darken it.
  ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);
  if (format) {
    // Named by its format, OpenImageIO creates that reader and nothing else. Given a path, it
    // asks the reader its extension names whether the file is valid and, when the answer is no,
    // tries every other reader it has (WebP, RAW, DICOM, HEIF, ...): for a damaged file that is
    // most of the time spent, and one of them allocated 78 MB for a 3 KB file.
    std::unique_ptr<ImageInput> in = ImageInput::create(format);
    if (!in) fail_read(path, OIIO::geterror());
    ImageSpec spec;
    if (!in->open(path, spec, config)) fail_read(path, in->geterror());
    return {std::move(in), std::move(spec)};
  }
  auto in = ImageInput::open(path, &config);
  if (!in) fail_read(path, OIIO::geterror());
  ImageSpec spec = in->spec();
  return {std::move(in), std::move(spec)};
}

// A read's allowance of values (pixels x channels), shared by the parts of a file.
struct ValueBudget {
  std::uint64_t limit, left;
  explicit ValueBudget(std::uint64_t max_values) : limit(max_values), left(max_values) {}
};

// All channels of the current subimage as float, interleaved. Their number, as the header
// declares it, is taken from `budget` first: a header may declare any size, and is refused
// before the memory is allocated.
std::vector<float> read_pixels(const std::string& path, ImageInput& in, const ImageSpec& spec,
                               int subimage, ValueBudget& budget) {
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0) fail_read(path, "empty image");
  if (spec.depth > 1) fail_read(path, "volume images are not supported");
  const std::uint64_t pixels = std::uint64_t(spec.width) * std::uint64_t(spec.height);
  const auto channels = std::uint64_t(spec.nchannels);
  if (channels > budget.left || pixels > budget.left / channels)
    fail_read(path, std::to_string(spec.width) + "x" + std::to_string(spec.height) + " pixels of " +
                        std::to_string(channels) + " channels exceed the image size limit (" +
                        std::to_string(budget.limit) + " values in all)");
  budget.left -= pixels * channels;
  std::vector<float> values(static_cast<size_t>(pixels) * spec.nchannels);
  // Scanline images (all that dofcache writes, and most EXR and PNG files) are read in their
  // own formats and converted here: read_image stages every call through a 64 MB buffer, whatever
  // the image's size (most of the time spent reading a small half-float file). Float ones are
  // read straight into `values`.
  bool ok;
  if (spec.tile_width != 0) {
    ok = in.read_image(subimage, 0, 0, spec.nchannels, TypeDesc::FLOAT, values.data());
  } else if (spec.format == TypeDesc::FLOAT && spec.channelformats.empty()) {
    ok = in.read_native_scanlines(subimage, 0, spec.y, spec.y + spec.height, spec.z, 0,
                                  spec.nchannels, values.data());
  } else {
    const auto pixel_bytes = static_cast<OIIO::stride_t>(spec.pixel_bytes(/*native=*/true));
    std::vector<char> native(static_cast<size_t>(pixels) * static_cast<size_t>(pixel_bytes));
    ok = in.read_native_scanlines(subimage, 0, spec.y, spec.y + spec.height, spec.z, 0,
                                  spec.nchannels, native.data());
    // Channel by channel: each may have its own format (channelformats).
    const auto float_pixel = static_cast<OIIO::stride_t>(sizeof(float) * channels);
    std::size_t offset = 0;
    for (int c = 0; ok && c < spec.nchannels; ++c) {
      const TypeDesc type = spec.channelformat(c);
      ok = OIIO::convert_image(1, spec.width, spec.height, 1, native.data() + offset, type,
                               pixel_bytes, pixel_bytes * spec.width, OIIO::AutoStride,
                               values.data() + c, TypeDesc::FLOAT, float_pixel,
                               float_pixel * spec.width, OIIO::AutoStride);
      offset += type.size();
    }
  }
  if (!ok) fail_read(path, in.geterror());
  return values;
}

// Copies the channels `indices` (in that order) of an interleaved buffer into a new image.
Image select_channels(const std::vector<float>& pixels, int width, int height, int stride,
                      const std::vector<int>& indices) {
  Image out(width, height, static_cast<int>(indices.size()));
  float* dst = out.data().data();
  for (size_t p = 0; p < out.pixel_count(); ++p) {
    const float* src = pixels.data() + p * stride;
    for (int c : indices) *dst++ = src[c];
  }
  return out;
}

int channel_index(const ImageSpec& spec, const std::string& name) {
  for (int c = 0; c < spec.nchannels; ++c)
    if (spec.channel_name(c) == name) return c;
  return -1;
}

std::vector<std::string> channel_names(const ImageSpec& spec) {
  std::vector<std::string> names;
  for (int c = 0; c < spec.nchannels; ++c) names.emplace_back(spec.channel_name(c));
  return names;
}

// 8/16-bit files hold display-encoded (sRGB) values unless they say otherwise; float is linear.
bool is_srgb_encoded(const ImageSpec& spec) {
  if (spec.format.is_floating_point()) return false;
  std::string cs = spec.get_string_attribute("oiio:ColorSpace");
  std::transform(cs.begin(), cs.end(), cs.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return cs.rfind("lin", 0) != 0;
}

Image read_image(const std::string& path, std::uint64_t max_values) {
  ValueBudget budget(max_values);
  OpenedInput file = open_input(path, max_values);
  const ImageSpec& spec = file.spec;
  std::vector<float> pixels = read_pixels(path, *file.in, spec, 0, budget);

  // Prefer channels named R,G,B; otherwise a luminance "Y" or the first channel is grey, and a
  // file of three or more unnamed channels is taken as RGB in order. Alpha is never colour.
  std::vector<int> rgb = {channel_index(spec, "R"), channel_index(spec, "G"),
                          channel_index(spec, "B")};
  if (std::find(rgb.begin(), rgb.end(), -1) != rgb.end()) {
    int y = channel_index(spec, "Y");
    int colour_channels = spec.nchannels - (spec.alpha_channel >= 0 ? 1 : 0);
    if (y >= 0)
      rgb = {y, y, y};
    else if (colour_channels >= 3)
      rgb = {0, 1, 2};
    else
      rgb = {0, 0, 0};
  }
  Image out = select_channels(pixels, spec.width, spec.height, spec.nchannels, rgb);
  if (is_srgb_encoded(spec))
    for (float& v : out.data()) v = srgb_to_linear(v);
  return out;
}

Image read_channels(const std::string& path, const std::vector<std::string>& names,
                    std::uint64_t max_values) {
  ValueBudget budget(max_values);
  OpenedInput file = open_input(path, max_values);
  const ImageSpec& spec = file.spec;
  std::vector<int> indices;
  for (const std::string& name : names) {
    int c = channel_index(spec, name);
    if (c < 0)
      fail_read(path, "no channel '" + name + "' (it has " + join(channel_names(spec), ", ") + ")");
    indices.push_back(c);
  }
  std::vector<float> pixels = read_pixels(path, *file.in, spec, 0, budget);
  return select_channels(pixels, spec.width, spec.height, spec.nchannels, indices);
}

void write_multipart_exr(const std::string& tmp, const std::string& path,
                         const std::vector<ExrPart>& parts) {
  if (parts.empty()) fail_write(path, "no parts to write");
  std::vector<std::string> part_names;
  for (const ExrPart& part : parts) part_names.push_back(part.name);
  check_unique(path, part_names, "part");

  // OpenEXR requires one display window for all parts; each part's data window is its own size.
  int display_width = 0, display_height = 0;
  for (const ExrPart& part : parts) {
    display_width = std::max(display_width, part.image.width());
    display_height = std::max(display_height, part.image.height());
  }
  std::vector<ImageSpec> specs;
  for (const ExrPart& part : parts) {
    if (part.image.empty()) fail_write(path, "part '" + part.name + "' is empty");
    if (static_cast<int>(part.channel_names.size()) != part.image.channels())
      fail_write(path, "part '" + part.name + "' has " + std::to_string(part.channel_names.size()) +
                           " channel names for " + std::to_string(part.image.channels()) +
                           " channels");
    check_unique(path, part.channel_names, "channel in part '" + part.name + "'");
    ImageSpec spec = exr_spec(part.image.width(), part.image.height(), part.channel_names);
    spec.full_width = display_width;
    spec.full_height = display_height;
    spec.attribute("name", part.name);
    spec.attribute(kChannelOrderKey, join(part.channel_names, "\n"));
    for (const auto& [key, value] : part.attributes) {
      if (key.empty()) fail_write(path, "empty attribute name in part '" + part.name + "'");
      spec.attribute(kAttributePrefix + key, value);
    }
    specs.push_back(std::move(spec));
  }
  auto out = create_output(tmp, path);
  if (!out->supports("multiimage"))
    fail_write(path, "the EXR writer cannot write multi-part files");
  if (!out->open(tmp, static_cast<int>(specs.size()), specs.data()))
    fail_write(path, out->geterror());
  for (size_t i = 0; i < parts.size(); ++i) {
    if (i > 0 && !out->open(tmp, specs[i], ImageOutput::AppendSubimage))
      fail_write(path, out->geterror());
    if (!out->write_image(TypeDesc::FLOAT, parts[i].image.data().data()))
      fail_write(path, out->geterror());
  }
  if (!out->close()) fail_write(path, out->geterror());
}

std::vector<ExrPart> read_multipart_exr(const std::string& path, std::uint64_t max_values) {
  ValueBudget budget(max_values);
  OpenedInput file = open_input(path, max_values, "openexr");
  std::vector<ExrPart> parts;
  const std::string prefix = kAttributePrefix;
  for (int subimage = 0; file.in->seek_subimage(subimage, 0); ++subimage) {
    ImageSpec spec = file.in->spec();
    ExrPart part;
    part.name = spec.get_string_attribute("name");
    if (part.name.empty()) part.name = spec.get_string_attribute("oiio:subimagename");

    // Restore the written channel order if it is recorded and still matches the file.
    std::vector<std::string> file_names = channel_names(spec);
    std::vector<std::string> order = file_names;
    std::string recorded = spec.get_string_attribute(kChannelOrderKey);
    if (!recorded.empty()) {
      std::vector<std::string> wanted = split_lines(recorded);
      std::vector<std::string> a = wanted, b = file_names;
      std::sort(a.begin(), a.end());
      std::sort(b.begin(), b.end());
      if (a == b) order = wanted;
    }
    std::vector<int> indices;
    for (const std::string& name : order) indices.push_back(channel_index(spec, name));

    std::vector<float> pixels = read_pixels(path, *file.in, spec, subimage, budget);
    part.image = select_channels(pixels, spec.width, spec.height, spec.nchannels, indices);
    part.channel_names = order;
    for (const OIIO::ParamValue& p : spec.extra_attribs) {
      std::string key = p.name().string();
      if (key.size() > prefix.size() && key.compare(0, prefix.size(), prefix) == 0 &&
          p.type() == OIIO::TypeString)
        part.attributes[key.substr(prefix.size())] = p.get_string();
    }
    parts.push_back(std::move(part));
  }
  if (parts.empty()) fail_read(path, "no image parts");
  return parts;
}


// Every entry catches what the codec throws: exceptions do not cross the module boundary.
template <class Fn>
std::string guarded(Fn&& fn) noexcept {
  try {
    fn();
    return {};
  } catch (const std::exception& e) {
    return reason_line(e.what());
  } catch (...) {
    return "unknown error in the image codec";
  }
}

const codec::Table kTable = {
    codec::kAbiVersion,
    [](const std::string& path, std::uint64_t max_values, Image& out) {
      return guarded([&] { out = oiio::read_image(path, max_values); });
    },
    [](const std::string& path, const std::vector<std::string>& names, std::uint64_t max_values,
       Image& out) { return guarded([&] { out = oiio::read_channels(path, names, max_values); }); },
    [](const std::string& tmp, const std::string& path, const std::vector<ExrPart>& parts) {
      return guarded([&] { oiio::write_multipart_exr(tmp, path, parts); });
    },
    [](const std::string& path, std::uint64_t max_values, std::vector<ExrPart>& out) {
      return guarded([&] { out = oiio::read_multipart_exr(path, max_values); });
    },
};

}  // namespace
}  // namespace dofcache::image::oiio

extern "C" DOFCACHE_CODEC_EXPORT const dofcache::image::codec::Table* dofcache_image_codec() {
  return &dofcache::image::oiio::kTable;
}
