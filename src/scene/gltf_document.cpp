#include "dofcache/scene/gltf_document.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

#include <glm/gtc/type_ptr.hpp>
#include <nlohmann/json.hpp>
#include <zlib.h>

#include "dofcache/core/error.h"
#include "dofcache/core/file.h"

namespace dofcache::scene::gltf {
namespace {

// tinygltf's failure messages, made to say what is wrong in our words where they are terse.
std::string parser_error(const std::string& message, const std::string& base_dir) {
  if (message.empty()) return "not a valid glTF file";
  const std::string json_tag = "[json.exception.";
  if (message.compare(0, json_tag.size(), json_tag) == 0) {
    std::size_t end = message.find("] ");
    return "invalid JSON: " + (end == std::string::npos ? message : message.substr(end + 2));
  }
  const std::string not_found = "File not found : ";
  if (std::size_t at = message.find(not_found); at != std::string::npos)
    return "referenced file not found: " + message.substr(at + not_found.size()) +
           (base_dir.empty() ? "" : " (looked in " + base_dir + ")");
  return message;
}

bool is_glb(const std::string& data) { return data.size() >= 4 && data.compare(0, 4, "glTF") == 0; }

bool skip_image(tinygltf::Image*, const int, std::string*, std::string*, int, int,
                const unsigned char*, int, void*) {
  return true;
}

std::uint32_t big_endian(const unsigned char* p, int bytes) {
  std::uint32_t v = 0;
  for (int i = 0; i < bytes; ++i) v = v << 8 | p[i];
  return v;
}

// Why stb_image must not see a PNG, or "" if it may. stb_image allocates what a chunk declares
// before it checks that the file holds it (a 2 GB IDAT length in a 74-byte file), and inflates the
// image data into a buffer it grows without bound, so a few kilobytes of IDAT that inflate to
// gigabytes (a zlib bomb behind a small declared size) would exhaust memory. So every chunk must
// lie within the file, and the image data is inflated here first, into a scratch buffer, and
// refused once it passes what its IHDR allows: each row's filter byte and samples, twice over
// (Adam7 interlacing adds a few bytes per pass), plus a little. Not a PNG: "".
std::string png_refusal(const unsigned char* p, std::size_t size) {
  static const unsigned char kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (size < 8 || std::memcmp(p, kPng, 8) != 0) return "";
  if (size < 33 || std::memcmp(p + 12, "IHDR", 4) != 0) return "its PNG header is damaged";
  const std::uint64_t width = big_endian(p + 16, 4), height = big_endian(p + 20, 4);
  const std::uint64_t depth = p[24], colour = p[25];
  const std::uint64_t channels = colour == 0 ? 1 : colour == 2 ? 3 : colour == 3 ? 1
                                 : colour == 4 ? 2 : 4;
  const std::uint64_t row = 1 + (width * channels * std::max<std::uint64_t>(depth, 1) + 7) / 8;
  const std::uint64_t limit = 2 * height * row + 4096;
  z_stream z{};
  if (inflateInit(&z) != Z_OK) return "out of memory";
  unsigned char scratch[16384];
  std::uint64_t produced = 0;
  std::string refusal;
  bool inflating = true;
  for (std::size_t at = 8; at < size && refusal.empty();) {
    if (size - at < 12) {
      refusal = "its PNG data ends inside a chunk";
      break;
    }
    const std::uint64_t length = big_endian(p + at, 4);
    if (length > size - at - 12) {
      refusal = "a PNG chunk declares " + std::to_string(length) + " bytes, past the end of the data";
      break;
    }
    if (std::memcmp(p + at + 4, "IDAT", 4) == 0 && inflating) {
      z.next_in = const_cast<unsigned char*>(p + at + 8);
      z.avail_in = static_cast<uInt>(length);
      while (z.avail_in > 0) {
        z.next_out = scratch;
        z.avail_out = sizeof scratch;
        const int status = inflate(&z, Z_NO_FLUSH);
        produced += sizeof scratch - z.avail_out;
        if (produced > limit) {
          refusal = "its PNG data inflates to more than its " + std::to_string(width) + "x" +
                    std::to_string(height) + " pixels can hold";
          break;
        }
        if (status != Z_OK) {  // the end of the stream, or damaged data stb_image refuses
          inflating = false;
          break;
        }
      }
    } else if (std::memcmp(p + at + 4, "IEND", 4) == 0) {
      break;
    }
    at += 12 + static_cast<std::size_t>(length);
  }
  inflateEnd(&z);
  return refusal;
}

// What the image callback needs besides its arguments: the model being parsed (its buffers are
// read before the images) and the pixel budget.
struct ImageBudget {
  const tinygltf::Model* model = nullptr;
  std::uint64_t max_pixels = 0, used = 0;
};

// tinygltf's image callback: checks what tinygltf does not (that a bufferView image lies inside
// its buffer) and the pixel budget from the header, and only then lets stb_image decode. Formats
// whose size image_header_size cannot read are left undecoded (a texture using one is refused).
bool load_image(tinygltf::Image* image, const int index, std::string* err, std::string* warn,
                int req_width, int req_height, const unsigned char* bytes, int size,
                void* user_data) {
  auto& budget = *static_cast<ImageBudget*>(user_data);
  const std::string label = "image " + std::to_string(index) + gltf::quoted(image->name);
  if (image->bufferView >= 0) {  // tinygltf checked the index, not the byte range
    const tinygltf::BufferView& bv = budget.model->bufferViews[std::size_t(image->bufferView)];
    std::size_t buffer_size = std::size_t(bv.buffer) < budget.model->buffers.size()
                                  ? budget.model->buffers[std::size_t(bv.buffer)].data.size()
                                  : 0;
    if (bv.byteOffset > buffer_size || bv.byteLength > buffer_size - bv.byteOffset) {
      if (err) *err += label + ": bufferView " + std::to_string(image->bufferView) +
                       " exceeds its buffer\n";
      return false;
    }
  }
  std::uint32_t width = 0, height = 0;
  if (size <= 0 || !image_header_size(bytes, std::size_t(size), &width, &height)) return true;
  const std::uint64_t pixels = std::uint64_t{width} * height;
  if (pixels > budget.max_pixels - std::min(budget.used, budget.max_pixels)) {
    if (err)
      *err += label + ": " + std::to_string(width) + "x" + std::to_string(height) +
              " pixels exceed the texture limit (" + std::to_string(budget.max_pixels) +
              " pixels for all images of a file; raise it with --max-texture-pixels)\n";
    return false;
  }
  const std::string refusal = png_refusal(bytes, std::size_t(size));
  if (!refusal.empty()) {
    if (err) *err += label + ": " + refusal + "\n";
    return false;
  }
  budget.used += pixels;
  return tinygltf::LoadImageData(image, index, err, warn, req_width, req_height, bytes, size,
                                 nullptr);
}

// tinygltf 2.7 refuses an indices accessor without a bufferView, which is how Draco-compressed
// primitives without an uncompressed fallback are written (their indices are in the compressed
// data), with a message that does not say why. Such "indices" members are dropped before tinygltf
// parses the JSON (of a .gltf, or of a .glb's JSON chunk), so that the loader can refuse the
// primitive naming the extension. Anything unexpected leaves the bytes as they are for tinygltf.
std::string without_draco_indices(const std::string& json_text, bool* changed) {
  *changed = false;
  if (json_text.find("KHR_draco_mesh_compression") == std::string::npos) return json_text;
  nlohmann::json doc = nlohmann::json::parse(json_text, nullptr, /*allow_exceptions=*/false);
  if (!doc.is_object() || !doc.contains("meshes") || !doc["meshes"].is_array() ||
      !doc.contains("accessors") || !doc["accessors"].is_array())
    return json_text;
  const nlohmann::json& accessors = doc["accessors"];
  for (auto& mesh : doc["meshes"]) {
    if (!mesh.is_object() || !mesh.contains("primitives") || !mesh["primitives"].is_array())
      continue;
    for (auto& prim : mesh["primitives"]) {
      if (!prim.is_object() || !prim.contains("indices") || !prim["indices"].is_number_unsigned() ||
          !prim.contains("extensions") || !prim["extensions"].is_object() ||
          !prim["extensions"].contains("KHR_draco_mesh_compression"))
        continue;
      const auto index = prim["indices"].get<std::size_t>();
      if (index >= accessors.size() || !accessors[index].is_object() ||
          accessors[index].contains("bufferView") || accessors[index].contains("sparse"))
        continue;  // an uncompressed fallback, or not ours to judge
      prim.erase("indices");
      *changed = true;
    }
  }
  return *changed ? doc.dump() : json_text;
}

std::string draco_ready(const std::string& data) {
  bool changed = false;
  if (!is_glb(data)) {
    std::string out = without_draco_indices(data, &changed);
    return changed ? out : data;
  }
  // GLB: 12-byte header, then chunks of (length, type, bytes); the JSON chunk comes first.
  auto u32 = [&](std::size_t at) {
    std::uint32_t v;
    std::memcpy(&v, data.data() + at, 4);
    return v;
  };
  if (data.size() < 20 || u32(16) != 0x4E4F534Au || u32(12) > data.size() - 20) return data;
  const std::size_t json_length = u32(12);
  std::string json = without_draco_indices(data.substr(20, json_length), &changed);
  if (!changed) return data;
  json.append((4 - json.size() % 4) % 4, ' ');
  std::string rest = data.substr(20 + json_length);
  std::string out = data.substr(0, 12);
  auto put = [&](std::uint32_t v) { out.append(reinterpret_cast<const char*>(&v), 4); };
  put(static_cast<std::uint32_t>(json.size()));
  put(0x4E4F534Au);
  out += json;
  out += rest;
  const auto total = static_cast<std::uint32_t>(out.size());
  std::memcpy(&out[8], &total, 4);
  return out;
}

// glTF 2.0 makes an animation channel's `target.node` optional (an extension may name the target
// instead), but tinygltf 2.7 reports its absence as an error and drops the channel. Dropping it
// is all dofcache could do with such a channel too, so the two lines of that report are not
// passed on as a warning about a valid file (the Khronos sample AnimatedTriangle has one).
void drop_optional_channel_node_notes(std::string& notes) {
  for (const char* line : {"'node' property is missing.\n",
                           "`node` field is missing in animation.channels.target\n"})
    for (std::size_t at; (at = notes.find(line)) != std::string::npos;)
      notes.erase(at, std::strlen(line));
}

}  // namespace

std::string base_dir_of(const std::string& path) {
  std::filesystem::path base = std::filesystem::path(path).parent_path();
  return base.empty() ? std::string(".") : base.string();
}

Parsed parse(const std::string& original, const std::string& name, const std::string& base_dir,
             bool load_images, std::uint64_t max_image_pixels) {
  if (original.size() > 0xffffffffu) throw Error(name + ": file is too large (over 4 GiB)");
  const std::string data = draco_ready(original);
  tinygltf::TinyGLTF parser;
  Parsed parsed;
  ImageBudget budget{&parsed.model, max_image_pixels};
  if (load_images)
    parser.SetImageLoader(load_image, &budget);
  else
    parser.SetImageLoader(skip_image, nullptr);
  std::string err, warn;
  bool ok;
  if (is_glb(data)) {
    ok = parser.LoadBinaryFromMemory(&parsed.model, &err, &warn,
                                     reinterpret_cast<const unsigned char*>(data.data()),
                                     static_cast<unsigned int>(data.size()), base_dir);
  } else {
    ok = parser.LoadASCIIFromString(&parsed.model, &err, &warn, data.data(),
                                    static_cast<unsigned int>(data.size()), base_dir);
  }
  if (!ok) throw Error(name + ": " + parser_error(one_line(err), base_dir));
  drop_optional_channel_node_notes(err);
  for (const std::string* note : {&warn, &err})
    if (!note->empty()) parsed.warnings.push_back(name + ": " + one_line(*note));
  return parsed;
}

bool image_header_size(const unsigned char* p, std::size_t size, std::uint32_t* width,
                       std::uint32_t* height) {
  static const unsigned char kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (size >= 24 && std::memcmp(p, kPng, 8) == 0) {  // the IHDR chunk comes first
    if (std::memcmp(p + 12, "IHDR", 4) != 0) return false;
    *width = big_endian(p + 16, 4);
    *height = big_endian(p + 20, 4);
    return true;
  }
  auto little_endian = [&](std::size_t at, int bytes) {
    std::uint32_t v = 0;
    for (int i = bytes - 1; i >= 0; --i) v = v << 8 | p[at + std::size_t(i)];
    return v;
  };
  if (size >= 26 && p[0] == 'B' && p[1] == 'M') {  // BMP: the DIB header's size says which
    bool core = little_endian(14, 4) == 12;
    auto magnitude = [](std::uint32_t v) { return v & 0x80000000u ? 0u - v : v; };  // top-down
    *width = core ? little_endian(18, 2) : magnitude(little_endian(18, 4));
    *height = core ? little_endian(20, 2) : magnitude(little_endian(22, 4));
    return true;
  }
  if (size >= 10 && std::memcmp(p, "GIF8", 4) == 0) {
    *width = little_endian(6, 2);
    *height = little_endian(8, 2);
    return true;
  }
  if (size < 4 || p[0] != 0xff || p[1] != 0xd8) return false;
  // JPEG: walk the marker segments to the first start-of-frame (SOF0-SOF15 but DHT, JPG, DAC).
  std::size_t at = 2;
  while (at + 4 <= size) {
    if (p[at] != 0xff) return false;
    unsigned marker = p[at + 1];
    if (marker == 0xff) {  // fill byte
      ++at;
      continue;
    }
    if (marker == 0x01 || (marker >= 0xd0 && marker <= 0xd8)) {  // no length
      at += 2;
      continue;
    }
    if (marker == 0xd9 || marker == 0xda) return false;  // end of image, or data without a frame
    std::size_t length = big_endian(p + at + 2, 2);
    if (length < 2) return false;
    bool frame = marker >= 0xc0 && marker <= 0xcf && marker != 0xc4 && marker != 0xc8 &&
                 marker != 0xcc;
    if (frame) {
      if (length < 7 || at + 9 > size) return false;
      *height = big_endian(p + at + 5, 2);
      *width = big_endian(p + at + 7, 2);
      return true;
    }
    at += 2 + length;
  }
  return false;
}

// Names come from the file and may hold line breaks; errors quoting them stay one line.
std::string quoted(const std::string& name) {
  return name.empty() ? "" : " '" + one_line(name) + "'";
}

const char* type_name(int type) {
  switch (type) {
    case TINYGLTF_TYPE_SCALAR:
      return "SCALAR";
    case TINYGLTF_TYPE_VEC2:
      return "VEC2";
    case TINYGLTF_TYPE_VEC3:
      return "VEC3";
    default:
      return "VEC4";
  }
}

void Document::fail(const std::string& element, const std::string& problem) const {
  throw Error(one_line(name_ + ": " + element + ": " + problem));  // problems may quote the file
}

std::string Document::node_label(int node) const {
  return "node" + quoted(model_.nodes[static_cast<std::size_t>(node)].name) + " (" +
         std::to_string(node) + ")";
}

std::string Document::mesh_label(int mesh) const {
  return "mesh" + quoted(model_.meshes[static_cast<std::size_t>(mesh)].name) + " (" +
         std::to_string(mesh) + ")";
}

AccessorView Document::accessor(int index, int expected_type, const std::string& user) const {
  const tinygltf::Accessor& acc = at(model_.accessors, index, "accessor", user);
  std::string label = "accessor " + std::to_string(index) + quoted(acc.name) + " (" + user + ")";
  int size = tinygltf::GetComponentSizeInBytes(static_cast<std::uint32_t>(acc.componentType));
  int components = tinygltf::GetNumComponentsInType(static_cast<std::uint32_t>(acc.type));
  if (size <= 0 || acc.componentType == TINYGLTF_COMPONENT_TYPE_DOUBLE)
    fail(label, "invalid componentType " + std::to_string(acc.componentType));
  if (components <= 0 || acc.type != expected_type)
    fail(label, std::string("must be of type ") + type_name(expected_type));
  AccessorView view;
  view.count = acc.count;
  view.components = components;
  view.component_type = acc.componentType;
  view.normalized = acc.normalized;
  auto element = static_cast<std::size_t>(size) * static_cast<std::size_t>(components);
  if (acc.bufferView == -1) {  // no data: all zeros (glTF 3.6.2.2)
    // Nothing bounds the count by real bytes here; refuse absurd ones before allocating.
    if (acc.count > (std::size_t{1} << 24))
      fail(label, "has no bufferView and an implausible count " + std::to_string(acc.count));
    if (acc.sparse.isSparse) make_dense(acc, label, element, view);
    return view;
  }

  const tinygltf::BufferView& bv = at(model_.bufferViews, acc.bufferView, "bufferView", label);
  std::string bv_label = "bufferView " + std::to_string(acc.bufferView);
  // The whole view, checked against its buffer.
  const unsigned char* start = view_bytes(acc.bufferView, 0, bv.byteLength, label);
  view.stride = bv.byteStride != 0 ? bv.byteStride : element;
  if (view.stride < element)
    fail(bv_label, "byteStride " + std::to_string(bv.byteStride) +
                       " is smaller than one element (" + std::to_string(element) + " bytes)");
  if (acc.count > 0) {
    // offset + (count - 1) * stride + element <= byteLength, without overflow.
    std::size_t available = bv.byteLength;
    bool fits = acc.byteOffset <= available && element <= available - acc.byteOffset &&
                acc.count - 1 <= (available - acc.byteOffset - element) / view.stride;
    if (!fits)
      fail(label, "byteOffset " + std::to_string(acc.byteOffset) + " + " +
                      std::to_string(acc.count) + " elements of stride " +
                      std::to_string(view.stride) + " exceed " + bv_label + " (" +
                      std::to_string(bv.byteLength) + " bytes)");
  }
  view.data = start + acc.byteOffset;
  if (acc.sparse.isSparse) make_dense(acc, label, element, view);
  return view;
}

const unsigned char* Document::view_bytes(int view, std::size_t offset, std::size_t bytes,
                                          const std::string& user) const {
  const tinygltf::BufferView& bv = at(model_.bufferViews, view, "bufferView", user);
  std::string bv_label = "bufferView " + std::to_string(view);
  const tinygltf::Buffer& buffer = at(model_.buffers, bv.buffer, "buffer", bv_label);
  if (bv.byteOffset > buffer.data.size() || bv.byteLength > buffer.data.size() - bv.byteOffset)
    fail(bv_label, "byte range " + std::to_string(bv.byteOffset) + "+" +
                       std::to_string(bv.byteLength) + " exceeds buffer " +
                       std::to_string(bv.buffer) + " (" + std::to_string(buffer.data.size()) +
                       " bytes)");
  if (offset > bv.byteLength || bytes > bv.byteLength - offset)
    fail(user, "byteOffset " + std::to_string(offset) + " + " + std::to_string(bytes) +
                   " bytes exceed " + bv_label + " (" + std::to_string(bv.byteLength) + " bytes)");
  return buffer.data.data() + bv.byteOffset + offset;
}

void Document::make_dense(const tinygltf::Accessor& acc, const std::string& label,
                          std::size_t element, AccessorView& view) const {
  const auto& sparse = acc.sparse;
  const auto count = static_cast<std::size_t>(std::max(sparse.count, 0));
  if (sparse.count < 1 || count > acc.count)
    fail(label, "sparse count " + std::to_string(sparse.count) + " must be in [1, " +
                    std::to_string(acc.count) + "] (the accessor's count)");
  const int index_type = sparse.indices.componentType;
  if (index_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
      index_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
      index_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
    fail(label, "sparse indices componentType must be an unsigned integer type");
  if (sparse.indices.byteOffset < 0 || sparse.values.byteOffset < 0)
    fail(label, "sparse byteOffset must not be negative");
  AccessorView indices;
  indices.component_type = index_type;
  indices.stride = static_cast<std::size_t>(
      tinygltf::GetComponentSizeInBytes(static_cast<std::uint32_t>(index_type)));
  indices.count = count;
  indices.data = view_bytes(sparse.indices.bufferView,
                            static_cast<std::size_t>(sparse.indices.byteOffset),
                            count * indices.stride, label + " sparse indices");
  const unsigned char* values =
      view_bytes(sparse.values.bufferView, static_cast<std::size_t>(sparse.values.byteOffset),
                 count * element, label + " sparse values");

  auto dense = std::make_shared<std::vector<unsigned char>>(acc.count * element, 0);
  if (view.data)
    for (std::size_t i = 0; i < acc.count; ++i)
      std::memcpy(dense->data() + i * element, view.data + i * view.stride, element);
  std::uint32_t previous = 0;
  for (std::size_t k = 0; k < count; ++k) {
    const std::uint32_t i = indices.index(k);
    if (i >= acc.count)
      fail(label, "sparse index " + std::to_string(i) + " at position " + std::to_string(k) +
                      " is out of range (" + std::to_string(acc.count) + " elements)");
    if (k > 0 && i <= previous)
      fail(label, "sparse indices must strictly increase (" + std::to_string(i) + " after " +
                      std::to_string(previous) + " at position " + std::to_string(k) + ")");
    previous = i;
    std::memcpy(dense->data() + std::size_t{i} * element, values + k * element, element);
  }
  view.data = dense->data();
  view.stride = element;
  view.dense = std::move(dense);
}

NodeTransform Document::node_transform(int n) const {
  const tinygltf::Node& node = model_.nodes[static_cast<std::size_t>(n)];
  NodeTransform tf;
  if (!node.matrix.empty()) {
    if (node.matrix.size() != 16) fail(node_label(n), "matrix must have 16 numbers");
    glm::dmat4 m = glm::make_mat4(node.matrix.data());  // column-major, as glTF stores it
    for (int c = 0; c < 4; ++c)
      for (int r = 0; r < 4; ++r)
        if (!std::isfinite(m[c][r])) fail(node_label(n), "matrix is not finite");
    tf.matrix = m;
    return tf;
  }
  if (!node.translation.empty()) {
    if (node.translation.size() != 3) fail(node_label(n), "translation must have 3 numbers");
    tf.translation = glm::dvec3(node.translation[0], node.translation[1], node.translation[2]);
  }
  if (!node.rotation.empty()) {
    if (node.rotation.size() != 4) fail(node_label(n), "rotation must have 4 numbers");
    // glTF stores (x, y, z, w); glm's constructor takes w first.
    glm::dquat q(node.rotation[3], node.rotation[0], node.rotation[1], node.rotation[2]);
    double len = glm::length(q);
    if (!(len > 0.0) || !std::isfinite(len))
      fail(node_label(n), "rotation is not a unit quaternion");
    tf.rotation = q / len;
  }
  if (!node.scale.empty()) {
    if (node.scale.size() != 3) fail(node_label(n), "scale must have 3 numbers");
    tf.scale = glm::dvec3(node.scale[0], node.scale[1], node.scale[2]);
  }
  glm::dmat4 m = tf.local();
  for (int c = 0; c < 4; ++c)
    for (int k = 0; k < 4; ++k)
      if (!std::isfinite(m[c][k])) fail(node_label(n), "transform is not finite");
  return tf;
}

}  // namespace dofcache::scene::gltf
