#pragma once
// Small glTF files built in tests: a base64 encoder, a buffer/accessor builder and a BMP writer
// (stb decodes BMP like PNG, and it takes a few lines to write). Shared by the glTF loader tests.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include "dofcache/core/error.h"

namespace dofcache::scene::test {

inline std::string base64(const std::vector<unsigned char>& bytes) {
  static const char* kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (std::size_t i = 0; i < bytes.size(); i += 3) {
    std::uint32_t n = bytes[i] << 16;
    if (i + 1 < bytes.size()) n |= bytes[i + 1] << 8;
    if (i + 2 < bytes.size()) n |= bytes[i + 2];
    out += kAlphabet[(n >> 18) & 63];
    out += kAlphabet[(n >> 12) & 63];
    out += i + 1 < bytes.size() ? kAlphabet[(n >> 6) & 63] : '=';
    out += i + 2 < bytes.size() ? kAlphabet[n & 63] : '=';
  }
  return out;
}

// Builds the binary part of a glTF: each add_* appends one bufferView and one accessor and
// returns the accessor index; json() wraps the caller's nodes/meshes/... around them.
class Gltf {
 public:
  static int components(const std::string& type) {
    return type == "VEC2" ? 2 : type == "VEC3" ? 3 : type == "VEC4" ? 4 : 1;
  }
  int add_floats(const std::vector<float>& values, const std::string& type) {
    return add(values.data(), values.size() * sizeof(float), 5126,
               values.size() / components(type), type);
  }
  // Signed integers (KHR_mesh_quantization): BYTE (5120) and SHORT (5122). Elements of 3 bytes
  // or 3 shorts are padded to 4-byte strides, as glTF requires of vertex attributes.
  int add_i8(const std::vector<std::int8_t>& v, const std::string& type, bool normalized) {
    return add_padded(v.data(), 1, v.size(), 5120, type, normalized);
  }
  int add_i16(const std::vector<std::int16_t>& v, const std::string& type, bool normalized) {
    return add_padded(v.data(), 2, v.size(), 5122, type, normalized);
  }
  int add_padded(const void* data, std::size_t size, std::size_t values, int component,
                 const std::string& type, bool normalized) {
    std::size_t n = static_cast<std::size_t>(components(type)), element = n * size;
    std::size_t stride = (element + 3) / 4 * 4, count = values / n;
    std::vector<unsigned char> bytes(count * stride, 0);
    for (std::size_t i = 0; i < count; ++i)
      std::memcpy(&bytes[i * stride], static_cast<const unsigned char*>(data) + i * element,
                  element);
    int view = add_view(bytes.data(), bytes.size(), stride == element ? 0 : stride);
    return add_accessor_json("{\"bufferView\":" + std::to_string(view) +
                             ",\"componentType\":" + std::to_string(component) +
                             ",\"count\":" + std::to_string(count) + ",\"type\":\"" + type +
                             "\"" + (normalized ? ",\"normalized\":true" : "") + "}");
  }
  int add_u8(const std::vector<std::uint8_t>& v, const std::string& type = "SCALAR",
             bool normalized = false) {
    return add(v.data(), v.size(), 5121, v.size() / components(type), type, normalized);
  }
  int add_u16(const std::vector<std::uint16_t>& v, const std::string& type = "SCALAR",
              bool normalized = false) {
    return add(v.data(), v.size() * 2, 5123, v.size() / components(type), type, normalized);
  }
  int add_u32(const std::vector<std::uint32_t>& v) {
    return add(v.data(), v.size() * 4, 5125, v.size(), "SCALAR");
  }
  // A raw accessor (for bad input): the caller writes the JSON object.
  int add_accessor_json(const std::string& json) {
    accessors_ += (accessors_.empty() ? "" : ",") + json;
    return count_++;
  }
  // A raw bufferView (for bad input): the caller writes the JSON object.
  int add_view_json(const std::string& json) {
    views_ += (views_.empty() ? "" : ",") + json;
    return views_count_++;
  }
  int add_view(const void* data, std::size_t bytes, std::size_t stride = 0) {
    while (bin_.size() % 4) bin_.push_back(0);
    views_ += std::string(views_.empty() ? "" : ",") +
              "{\"buffer\":0,\"byteOffset\":" + std::to_string(bin_.size()) +
              ",\"byteLength\":" + std::to_string(bytes) +
              (stride ? ",\"byteStride\":" + std::to_string(stride) : std::string()) + "}";
    auto p = static_cast<const unsigned char*>(data);
    bin_.insert(bin_.end(), p, p + bytes);
    return views_count_++;
  }
  std::size_t bin_size() const { return bin_.size(); }

  // `rest` holds the remaining top-level members, e.g. "\"nodes\":[...],\"meshes\":[...]".
  // `buffer_uri` replaces the data URI (for missing-file tests).
  std::string json(const std::string& rest, const std::string& buffer_uri = "") const {
    std::string uri =
        buffer_uri.empty() ? "data:application/octet-stream;base64," + base64(bin_) : buffer_uri;
    return "{\"asset\":{\"version\":\"2.0\"},\"bufferViews\":[" + views_ + "],\"accessors\":[" +
           accessors_ + "],\"buffers\":[{\"byteLength\":" + std::to_string(bin_.size()) +
           ",\"uri\":\"" + uri + "\"}]," + rest + "}";
  }

 private:
  int add(const void* data, std::size_t bytes, int component, std::size_t count,
          const std::string& type, bool normalized = false) {
    int view = add_view(data, bytes);
    return add_accessor_json("{\"bufferView\":" + std::to_string(view) +
                             ",\"componentType\":" + std::to_string(component) +
                             ",\"count\":" + std::to_string(count) + ",\"type\":\"" + type + "\"" +
                             (normalized ? ",\"normalized\":true" : "") + "}");
  }

  std::vector<unsigned char> bin_;
  std::string views_, accessors_;
  int count_ = 0, views_count_ = 0;
};

// A 24-bit BMP (stb decodes it like a PNG). pixels: row 0 is the top; RGB.
inline std::vector<unsigned char> bmp(int w, int h, const std::vector<std::uint8_t>& rgb) {
  int row = (3 * w + 3) / 4 * 4;
  std::vector<unsigned char> out(54 + static_cast<std::size_t>(row) * h, 0);
  auto u32 = [&](std::size_t at, std::uint32_t v) { std::memcpy(&out[at], &v, 4); };
  out[0] = 'B', out[1] = 'M';
  u32(2, static_cast<std::uint32_t>(out.size()));
  u32(10, 54);
  u32(14, 40);
  u32(18, static_cast<std::uint32_t>(w));
  u32(22, static_cast<std::uint32_t>(h));
  out[26] = 1, out[28] = 24;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      std::size_t dst = 54 + static_cast<std::size_t>(h - 1 - y) * row + 3 * x;  // bottom-up
      std::size_t src = 3 * (static_cast<std::size_t>(y) * w + x);
      out[dst] = rgb[src + 2], out[dst + 1] = rgb[src + 1], out[dst + 2] = rgb[src];
    }
  return out;
}

// `load` throws one dofcache::Error, of one line, containing each of `parts`.
inline void expect_error(const std::function<void()>& load, const std::vector<std::string>& parts) {
  try {
    load();
    ADD_FAILURE() << "expected dofcache::Error";
  } catch (const Error& e) {
    std::string m = e.what();
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
    for (const std::string& part : parts)
      EXPECT_NE(m.find(part), std::string::npos) << "'" << part << "' not in: " << m;
  }
}

}  // namespace dofcache::scene::test
