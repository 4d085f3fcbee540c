#include "dofcache/scene/gltf_document.h"

#include <cerrno>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>

#include <glm/gtc/type_ptr.hpp>

#include "dofcache/core/error.h"

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

}  // namespace

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot open file (" + std::strerror(errno) + ")");
  std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw Error(path + ": read error");
  return data;
}

std::string base_dir_of(const std::string& path) {
  std::filesystem::path base = std::filesystem::path(path).parent_path();
  return base.empty() ? std::string(".") : base.string();
}

Parsed parse(const std::string& data, const std::string& name, const std::string& base_dir,
             bool load_images) {
  if (data.size() > 0xffffffffu) throw Error(name + ": file is too large (over 4 GiB)");
  tinygltf::TinyGLTF parser;
  if (!load_images) parser.SetImageLoader(skip_image, nullptr);
  Parsed parsed;
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
  for (const std::string* note : {&warn, &err})
    if (!note->empty()) parsed.warnings.push_back(name + ": " + one_line(*note));
  return parsed;
}

std::string quoted(const std::string& name) { return name.empty() ? "" : " '" + name + "'"; }

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
  throw Error(name_ + ": " + element + ": " + problem);
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
  if (acc.sparse.isSparse) fail(label, "sparse accessors are not supported");
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
    return view;
  }

  const tinygltf::BufferView& bv = at(model_.bufferViews, acc.bufferView, "bufferView", label);
  std::string bv_label = "bufferView " + std::to_string(acc.bufferView);
  const tinygltf::Buffer& buffer = at(model_.buffers, bv.buffer, "buffer", bv_label);
  if (bv.byteOffset > buffer.data.size() || bv.byteLength > buffer.data.size() - bv.byteOffset)
    fail(bv_label, "byte range " + std::to_string(bv.byteOffset) + "+" +
                       std::to_string(bv.byteLength) + " exceeds buffer " +
                       std::to_string(bv.buffer) + " (" + std::to_string(buffer.data.size()) +
                       " bytes)");
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
  view.data = buffer.data.data() + bv.byteOffset + acc.byteOffset;
  return view;
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
