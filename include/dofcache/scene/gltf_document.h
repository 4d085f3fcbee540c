#pragma once
// The glTF document layer: reading a .gltf/.glb file with tinygltf and everything both of its
// readers need, defined once: the scene loader (gltf_loader.cpp) and the camera paths of
// sequences (sequence/gltf_path.cpp). Parsing and its messages, labels and index checks, accessor
// decoding with every byte range checked, and validated node transforms (transform.h).
// Include it only where tinygltf is used anyway (those two translation units).
#include <tiny_gltf.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "dofcache/scene/transform.h"

namespace dofcache::scene::gltf {

// The directory relative resources (buffers, images) are looked up in: the file's, or ".".
std::string base_dir_of(const std::string& path);

struct Parsed {
  tinygltf::Model model;
  std::vector<std::string> warnings;  // tinygltf's non-fatal complaints, one line each
};
// Parses glTF JSON or GLB bytes (by their magic). Images are decoded only if `load_images`, and
// only PNG and JPEG ones (the formats glTF allows) and BMP and GIF: their sizes are read from the
// headers first and the file is refused if they add up to more than `max_image_pixels`. Throws dofcache::Error
// "<name>: <problem>" (one line, in our words where tinygltf is terse).
Parsed parse(const std::string& data, const std::string& name, const std::string& base_dir,
             bool load_images, std::uint64_t max_image_pixels = 0);

// Width and height from a PNG, JPEG, BMP or GIF header (false for another format or a broken
// header).
bool image_header_size(const unsigned char* bytes, std::size_t size, std::uint32_t* width,
                       std::uint32_t* height);

// " 'name'", or "" for an unnamed element.
std::string quoted(const std::string& name);
const char* type_name(int type);  // TINYGLTF_TYPE_* -> "SCALAR", "VEC2", ...

// An accessor's elements, range-checked by Document::accessor.
struct AccessorView {
  const unsigned char* data = nullptr;  // nullptr: no bufferView, all elements are zero
  std::size_t count = 0, stride = 0;
  int components = 0, component_type = 0;
  bool normalized = false;
  // A sparse accessor's elements, made dense (base values with the substitutions applied);
  // `data` points into it.
  std::shared_ptr<const std::vector<unsigned char>> dense;

  // Component c of an element as T (float or double); normalised integers map to [0,1] or
  // [-1,1] (glTF 3.11), computed in T.
  template <class T>
  T component(std::size_t element, int c) const {
    if (!data) return T(0);
    const unsigned char* p = data + element * stride;
    switch (component_type) {
      case TINYGLTF_COMPONENT_TYPE_FLOAT: {
        float f;
        std::memcpy(&f, p + 4 * c, 4);
        return static_cast<T>(f);
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: {
        T v = p[c];
        return normalized ? v / T(255) : v;
      }
      case TINYGLTF_COMPONENT_TYPE_BYTE: {
        T v = static_cast<signed char>(p[c]);
        return normalized ? std::max(v / T(127), T(-1)) : v;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
        std::uint16_t u;
        std::memcpy(&u, p + 2 * c, 2);
        return normalized ? u / T(65535) : static_cast<T>(u);
      }
      case TINYGLTF_COMPONENT_TYPE_SHORT: {
        std::int16_t s;
        std::memcpy(&s, p + 2 * c, 2);
        return normalized ? std::max(s / T(32767), T(-1)) : static_cast<T>(s);
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
        std::uint32_t u;
        std::memcpy(&u, p + 4 * c, 4);
        return static_cast<T>(u);
      }
      default:
        return T(0);
    }
  }

  // Element `element` of an index accessor (UNSIGNED_BYTE, _SHORT or _INT).
  std::uint32_t index(std::size_t element) const {
    if (!data) return 0;
    const unsigned char* p = data + element * stride;
    switch (component_type) {
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
        return p[0];
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
        std::uint16_t u;
        std::memcpy(&u, p, 2);
        return u;
      }
      default: {
        std::uint32_t u;
        std::memcpy(&u, p, 4);
        return u;
      }
    }
  }
};

// A parsed model and the file's name, with the checks every reader of it makes. Every failure
// throws dofcache::Error "<name>: <element>: <problem>".
class Document {
 public:
  Document(const tinygltf::Model& model, std::string name)
      : model_(model), name_(std::move(name)) {}

  [[noreturn]] void fail(const std::string& element, const std::string& problem) const;

  // items[index], or a failure naming `user` (the element that refers to it).
  template <class T>
  const T& at(const std::vector<T>& items, int index, const char* kind,
              const std::string& user) const {
    if (index < 0 || static_cast<std::size_t>(index) >= items.size())
      fail(user, std::string(kind) + " index " + std::to_string(index) +
                     " is out of range (the file has " + std::to_string(items.size()) + ")");
    return items[static_cast<std::size_t>(index)];
  }

  std::string node_label(int node) const;  // "node 'name' (3)"
  std::string mesh_label(int mesh) const;

  // Accessor `index` of type `expected_type` (TINYGLTF_TYPE_*), used by `user`: a valid
  // component type (not DOUBLE), and every element inside its buffer view and buffer. A sparse
  // accessor is returned dense, after checking that its indices strictly increase and stay below
  // its count and that its index and value arrays lie inside their buffer views.
  AccessorView accessor(int index, int expected_type, const std::string& user) const;
  // `bytes` bytes at `offset` into bufferView `view`, checked against the view and its buffer.
  const unsigned char* view_bytes(int view, std::size_t offset, std::size_t bytes,
                                  const std::string& user) const;
  // The type (TINYGLTF_TYPE_*) accessor `index` declares, for attributes that allow several.
  int accessor_type(int index, const std::string& user) const {
    return at(model_.accessors, index, "accessor", user).type;
  }

  // The node's local transform: a matrix of 16 finite numbers, or translation (3 numbers),
  // rotation (4, a quaternion that is normalised) and scale (3) whose product is finite.
  NodeTransform node_transform(int node) const;

 protected:
  // Copies the accessor into a dense array and applies its sparse substitutions.
  void make_dense(const tinygltf::Accessor& acc, const std::string& label, std::size_t element,
                  AccessorView& view) const;

  const tinygltf::Model& model_;
  std::string name_;
};

}  // namespace dofcache::scene::gltf
