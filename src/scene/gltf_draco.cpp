#include "dofcache/scene/gltf_draco.h"

#include <draco/compression/decode.h>

#include <cstdint>
#include <memory>
#include <vector>

#include "dofcache/core/error.h"

namespace dofcache::scene::gltf {
namespace {

// Components each attribute the loader reads must have (0: 3 or 4, COLOR_0).
int expected_components(const std::string& name) {
  if (name == "POSITION" || name == "NORMAL") return 3;
  if (name == "TANGENT") return 4;
  if (name.compare(0, 9, "TEXCOORD_") == 0) return 2;
  if (name.compare(0, 6, "COLOR_") == 0) return 0;
  return -1;  // not read: decoded only if asked for
}

}  // namespace

DracoPrimitive decode_draco(const Document& doc, const tinygltf::Model& model,
                            const tinygltf::Primitive& primitive, const tinygltf::Value& ext,
                            const std::string& label) {
  const std::string where = label + " " + kDracoExtension;
  if (!ext.IsObject()) doc.fail(where, "must be an object");
  const tinygltf::Value& view_value = ext.Get("bufferView");
  const tinygltf::Value& attributes = ext.Get("attributes");
  if (!view_value.IsInt()) doc.fail(where, "has no bufferView");
  if (!attributes.IsObject()) doc.fail(where, "has no attributes object");
  if (primitive.mode != -1 && primitive.mode != TINYGLTF_MODE_TRIANGLES)
    doc.fail(where, "only TRIANGLES primitives are supported compressed");
  const int view = view_value.Get<int>();
  const tinygltf::BufferView& bv = doc.at(model.bufferViews, view, "bufferView", where);
  const unsigned char* bytes = doc.view_bytes(view, 0, bv.byteLength, where);

  draco::DecoderBuffer buffer;
  buffer.Init(reinterpret_cast<const char*>(bytes), bv.byteLength);
  draco::Decoder decoder;
  auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
  if (!decoded.ok())
    doc.fail(where, "cannot decode the compressed mesh (" +
                        one_line(decoded.status().error_msg_string()) + ")");
  const std::unique_ptr<draco::Mesh> mesh = std::move(decoded).value();
  const std::size_t points = mesh->num_points(), faces = mesh->num_faces();

  auto declared = [&](int accessor) -> std::size_t {
    return accessor >= 0 && static_cast<std::size_t>(accessor) < model.accessors.size()
               ? model.accessors[static_cast<std::size_t>(accessor)].count
               : 0;
  };
  auto position = primitive.attributes.find("POSITION");
  if (position != primitive.attributes.end() && declared(position->second) != points)
    doc.fail(where, "decodes " + std::to_string(points) + " vertices, the POSITION accessor says " +
                        std::to_string(declared(position->second)));
  if (primitive.indices >= 0 && declared(primitive.indices) != 3 * faces)
    doc.fail(where, "decodes " + std::to_string(3 * faces) +
                        " indices, the indices accessor says " +
                        std::to_string(declared(primitive.indices)));

  DracoPrimitive out;
  for (const std::string& name : attributes.Keys()) {
    const int want = expected_components(name);
    if (want < 0) continue;
    const tinygltf::Value& id = attributes.Get(name);
    if (!id.IsInt() || id.Get<int>() < 0) doc.fail(where, "attribute " + name + " has no id");
    const draco::PointAttribute* a =
        mesh->GetAttributeByUniqueId(static_cast<std::uint32_t>(id.Get<int>()));
    if (!a) doc.fail(where, "attribute " + name + " (id " + std::to_string(id.Get<int>()) +
                                ") is not in the compressed mesh");
    const int n = a->num_components();
    if (want ? n != want : (n != 3 && n != 4))
      doc.fail(where, "attribute " + name + " has " + std::to_string(n) + " components");
    auto dense = std::make_shared<std::vector<unsigned char>>(points * n * sizeof(float));
    auto* values = reinterpret_cast<float*>(dense->data());
    for (std::size_t p = 0; p < points; ++p)
      if (!a->ConvertValue<float>(a->mapped_index(draco::PointIndex(static_cast<std::uint32_t>(p))),
                                  static_cast<std::int8_t>(n), values + p * n))
        doc.fail(where, "attribute " + name + " cannot be read as numbers");
    AccessorView v;
    v.data = dense->data();
    v.count = points;
    v.stride = n * sizeof(float);
    v.components = n;
    v.component_type = TINYGLTF_COMPONENT_TYPE_FLOAT;
    v.dense = std::move(dense);
    out.attributes[name] = v;
  }
  if (!out.attributes.count("POSITION")) doc.fail(where, "has no compressed POSITION");

  auto indices = std::make_shared<std::vector<unsigned char>>(3 * faces * sizeof(std::uint32_t));
  auto* index = reinterpret_cast<std::uint32_t*>(indices->data());
  for (std::size_t f = 0; f < faces; ++f) {
    const draco::Mesh::Face& face = mesh->face(draco::FaceIndex(static_cast<std::uint32_t>(f)));
    for (int c = 0; c < 3; ++c) index[3 * f + c] = face[c].value();
  }
  out.indices.data = indices->data();
  out.indices.count = 3 * faces;
  out.indices.stride = sizeof(std::uint32_t);
  out.indices.components = 1;
  out.indices.component_type = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
  out.indices.dense = std::move(indices);
  return out;
}

}  // namespace dofcache::scene::gltf
