#pragma once
// KHR_draco_mesh_compression: a primitive's compressed attributes and indices, decoded with
// Debian's Draco library into the same accessor views the loader reads uncompressed data through.
// Include it only where tinygltf is used anyway (gltf_loader.cpp).
#include <map>
#include <string>

#include "dofcache/scene/gltf_document.h"

namespace dofcache::scene::gltf {

inline constexpr const char* kDracoExtension = "KHR_draco_mesh_compression";

struct DracoPrimitive {
  std::map<std::string, AccessorView> attributes;  // by glTF name; FLOAT, dense
  AccessorView indices;                            // UNSIGNED_INT, three per triangle
};

// Decodes the extension object `ext` of primitive `label` (bufferView and attributes map). The
// decoded data must agree with the primitive's accessors (glTF: they describe it): as many
// points as the POSITION accessor's count (and as many indices as the indices accessor's, where
// one is left: gltf::parse drops it from compressed primitives, see gltf_document.cpp). Throws
// dofcache::Error "<name>: <label> KHR_draco_mesh_compression: <problem>".
DracoPrimitive decode_draco(const Document& doc, const tinygltf::Model& model,
                            const tinygltf::Primitive& primitive, const tinygltf::Value& ext,
                            const std::string& label);

}  // namespace dofcache::scene::gltf
