// Float EXR encoding with OpenEXR, in the image library itself rather than the codec module, as PNG
// is (png_encoder.cpp): a render that writes an EXR should not wait for OpenImageIO and the ~260
// libraries it links (codec_module.h), which take longer to load than a quick render takes.
#include <cstdint>
#include <cstring>
#include <set>
#include <string>
#include <vector>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfIO.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStringAttribute.h>

#include "dofcache/core/error.h"
#include "exr_encoder.h"

namespace dofcache::image {
namespace {

// An OpenEXR output stream into memory (OpenEXR seeks back to write the line offsets).
class MemoryStream final : public Imf::OStream {
 public:
  explicit MemoryStream(std::vector<unsigned char>* bytes) : OStream("memory.exr"), bytes_(bytes) {}

  void write(const char c[], int n) override {
    const std::uint64_t end = position_ + static_cast<std::uint64_t>(n);
    if (end > bytes_->size()) bytes_->resize(end);
    std::memcpy(bytes_->data() + position_, c, static_cast<std::size_t>(n));
    position_ = end;
  }
  std::uint64_t tellp() override { return position_; }
  void seekp(std::uint64_t pos) override { position_ = pos; }

 private:
  std::vector<unsigned char>* bytes_;
  std::uint64_t position_ = 0;
};

}  // namespace

std::vector<unsigned char> exr_bytes(const Image& color, const std::vector<NamedChannels>& extra,
                                     const std::string& context,
                                     const std::map<std::string, std::string>& attributes) {
  auto fail = [&](const std::string& reason) -> void { throw Error(context + ": " + reason); };
  if (color.empty() || color.channels() != 3) fail("colour must be a non-empty RGB image");
  const int width = color.width(), height = color.height();

  // Every channel: its name, and where its first value is in which image.
  struct Channel {
    std::string name;
    const Image* image;
    int index;
  };
  std::vector<Channel> channels = {{"R", &color, 0}, {"G", &color, 1}, {"B", &color, 2}};
  for (const NamedChannels& e : extra) {
    std::string names;
    for (const std::string& n : e.names) names += (names.empty() ? "" : ",") + n;
    if (e.image.width() != width || e.image.height() != height)
      fail("extra channels " + names + " are " + std::to_string(e.image.width()) + "x" +
           std::to_string(e.image.height()) + ", colour is " + std::to_string(width) + "x" +
           std::to_string(height));
    if (static_cast<int>(e.names.size()) != e.image.channels())
      fail(std::to_string(e.names.size()) + " names for an image of " +
           std::to_string(e.image.channels()) + " channels");
    for (int c = 0; c < e.image.channels(); ++c) channels.push_back({e.names[c], &e.image, c});
  }
  std::set<std::string> seen;
  for (const Channel& c : channels) {
    if (c.name.empty()) fail("empty channel name");
    if (!seen.insert(c.name).second) fail("duplicate channel '" + c.name + "'");
  }

  std::vector<unsigned char> bytes;
  try {
    Imf::Header header(width, height);
    header.compression() = Imf::ZIP_COMPRESSION;  // lossless and compact
    for (const auto& [key, value] : attributes)
      header.insert("dofcache:" + key, Imf::StringAttribute(value));
    Imf::FrameBuffer frame;
    for (const Channel& c : channels) {
      header.channels().insert(c.name, Imf::Channel(Imf::FLOAT));
      const std::size_t x_stride = sizeof(float) * static_cast<std::size_t>(c.image->channels());
      // OpenEXR writes from a non-const base; it only reads through it.
      auto* base = const_cast<float*>(c.image->data().data()) + c.index;
      frame.insert(c.name, Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(base), x_stride,
                                      x_stride * static_cast<std::size_t>(width)));
    }
    MemoryStream stream(&bytes);
    Imf::OutputFile file(stream, header);
    file.setFrameBuffer(frame);
    file.writePixels(height);
  } catch (const std::exception& e) {
    fail(one_line(e.what()));  // OpenEXR's messages can span several lines
  }
  return bytes;
}

std::vector<unsigned char> encode_exr(const Image& color) {
  return exr_bytes(color, {}, "cannot encode an EXR image");
}

}  // namespace dofcache::image
