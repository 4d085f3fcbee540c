#pragma once
// glTF materials and textures as the renderer's Material and Texture (scene.h): factors,
// textures with their TEXCOORD set and KHR_texture_transform, emissive strength, normal textures,
// alpha modes, sides. A reader of the glTF document (gltf_document.h), used by the scene loader.
// Include it only where tinygltf is used anyway (gltf_loader.cpp).
#include <map>
#include <string>
#include <vector>

#include "dofcache/scene/gltf_document.h"
#include "dofcache/scene/scene.h"

namespace dofcache::scene::gltf {

inline constexpr const char* kEmissiveStrengthExt = "KHR_materials_emissive_strength";
inline constexpr const char* kTextureTransformExt = "KHR_texture_transform";

class MaterialReader : Document {
 public:
  // Textures are appended to `textures` as materials first use them (each glTF texture once);
  // non-fatal notes go to `warnings`.
  MaterialReader(const tinygltf::Model& model, std::string name, std::vector<Texture>& textures,
                 std::vector<std::string>& warnings)
      : Document(model, std::move(name)), textures_(textures), warnings_(warnings) {}

  // glTF material `index` (in range). Throws dofcache::Error "<file>: material ...: <problem>".
  Material material(int index);

 private:
  void warn(const std::string& element, const std::string& note) {
    warnings_.push_back(name_ + ": " + element + ": " + note);
  }
  // A textureInfo (or normalTextureInfo): texture, TEXCOORD set and KHR_texture_transform.
  TextureRef texture_ref(int index, int texcoord, const tinygltf::ExtensionMap& extensions,
                         const std::string& user);
  // KHR_texture_transform's offset (2 numbers), rotation (radians), scale (2 numbers) and
  // texCoord (overriding the textureInfo's). Every number must be finite and at most 1e6 in
  // magnitude (beyond that, float texture coordinates have no precision left), texCoord >= 0.
  void read_texture_transform(const tinygltf::Value& ext, const std::string& label,
                              TextureRef& ref, int& texcoord) const;
  Texture convert_texture(int index);
  static Wrap wrap_mode(int gl);

  std::vector<Texture>& textures_;
  std::vector<std::string>& warnings_;
  std::map<int, int> texture_map_;  // glTF texture -> index in textures_
};

}  // namespace dofcache::scene::gltf
