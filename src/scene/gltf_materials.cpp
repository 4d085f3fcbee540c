#include "dofcache/scene/gltf_materials.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "dofcache/core/error.h"

namespace dofcache::scene::gltf {
namespace {

bool finite(glm::vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

}  // namespace

Material MaterialReader::material(int index) {
  const tinygltf::Material& gm = model_.materials[static_cast<std::size_t>(index)];
  std::string label = "material" + quoted(gm.name) + " (" + std::to_string(index) + ")";
  Material m;
  m.name = gm.name.empty() ? "material" + std::to_string(index) : gm.name;
  const auto& pbr = gm.pbrMetallicRoughness;
  if (pbr.baseColorFactor.size() == 4)
    m.base_color = glm::vec4(pbr.baseColorFactor[0], pbr.baseColorFactor[1],
                             pbr.baseColorFactor[2], pbr.baseColorFactor[3]);
  else if (!pbr.baseColorFactor.empty())
    fail(label, "baseColorFactor must have 4 numbers");
  m.metallic = static_cast<float>(pbr.metallicFactor);
  m.roughness = static_cast<float>(pbr.roughnessFactor);
  if (gm.emissiveFactor.size() == 3)
    m.emissive = glm::vec3(gm.emissiveFactor[0], gm.emissiveFactor[1], gm.emissiveFactor[2]);
  else if (!gm.emissiveFactor.empty())
    fail(label, "emissiveFactor must have 3 numbers");
  auto strength = gm.extensions.find(kEmissiveStrengthExt);
  if (strength != gm.extensions.end()) {
    const tinygltf::Value& s = strength->second.Get("emissiveStrength");
    if (s.IsNumber()) {
      double v = s.GetNumberAsDouble();
      if (!(v >= 0.0) || !std::isfinite(v))
        fail(label, std::string(kEmissiveStrengthExt) + ".emissiveStrength must be >= 0");
      m.emissive *= static_cast<float>(v);
    }
  }
  if (!finite(glm::vec3(m.base_color)) || !std::isfinite(m.metallic) ||
      !std::isfinite(m.roughness) || !finite(m.emissive))
    fail(label, "has a non-finite factor");
  const auto& bct = pbr.baseColorTexture;
  m.base_color_texture =
      texture_ref(bct.index, bct.texCoord, bct.extensions, label + " baseColorTexture");
  const auto& mrt = pbr.metallicRoughnessTexture;
  m.metallic_roughness_texture =
      texture_ref(mrt.index, mrt.texCoord, mrt.extensions, label + " metallicRoughnessTexture");
  const auto& et = gm.emissiveTexture;
  m.emissive_texture =
      texture_ref(et.index, et.texCoord, et.extensions, label + " emissiveTexture");
  const auto& nt = gm.normalTexture;
  m.normal_texture = texture_ref(nt.index, nt.texCoord, nt.extensions, label + " normalTexture");
  m.normal_scale = static_cast<float>(nt.scale);
  if (!std::isfinite(m.normal_scale)) fail(label, "normalTexture.scale is not finite");
  m.double_sided = gm.doubleSided;
  if (gm.alphaMode == "MASK") {
    m.alpha_mode = AlphaMode::Mask;
    m.alpha_cutoff = static_cast<float>(gm.alphaCutoff);
    if (!(m.alpha_cutoff >= 0.0f) || !std::isfinite(m.alpha_cutoff))
      fail(label, "alphaCutoff must be a number >= 0");
  } else if (gm.alphaMode == "BLEND") {
    m.alpha_mode = AlphaMode::Blend;
  } else if (gm.alphaMode != "OPAQUE" && !gm.alphaMode.empty()) {
    fail(label, "unknown alphaMode '" + gm.alphaMode + "' (OPAQUE, MASK or BLEND)");
  }
  if (!std::isfinite(m.base_color.a)) fail(label, "has a non-finite factor");
  return m;
}

TextureRef MaterialReader::texture_ref(int index, int texcoord,
                                     const tinygltf::ExtensionMap& extensions,
                                     const std::string& user) {
  TextureRef ref;
  if (index == -1) return ref;
  at(model_.textures, index, "texture", user);
  auto transform = extensions.find(kTextureTransformExt);
  if (transform != extensions.end())
    read_texture_transform(transform->second, user + " " + kTextureTransformExt, ref, texcoord);
  ref.texcoord = texcoord;
  if (texcoord != 0 && texcoord != 1) {
    warn(user, "texCoord " + std::to_string(texcoord) + " is not supported; TEXCOORD_0 used");
    ref.texcoord = 0;
  }
  auto it = texture_map_.find(index);
  if (it == texture_map_.end()) {
    it = texture_map_.emplace(index, static_cast<int>(textures_.size())).first;
    textures_.push_back(convert_texture(index));
  }
  ref.index = it->second;
  return ref;
}

void MaterialReader::read_texture_transform(const tinygltf::Value& ext, const std::string& label,
                                          TextureRef& ref, int& texcoord) const {
  if (!ext.IsObject()) fail(label, "must be an object");
  constexpr double kLimit = 1e6;
  auto number = [&](const tinygltf::Value& v, const std::string& key) {
    double d = v.IsNumber() ? v.GetNumberAsDouble() : std::nan("");
    if (!std::isfinite(d) || std::abs(d) > kLimit)
      fail(label, key + " must be a finite number of magnitude at most 1e6");
    return static_cast<float>(d);
  };
  auto pair = [&](const char* key, glm::vec2& out) {
    if (!ext.Has(key)) return;
    const tinygltf::Value& v = ext.Get(key);
    if (!v.IsArray() || v.ArrayLen() != 2) fail(label, std::string(key) + " must have 2 numbers");
    out = glm::vec2(number(v.Get(0), key), number(v.Get(1), key));
  };
  pair("offset", ref.offset);
  pair("scale", ref.scale);
  if (ext.Has("rotation")) ref.rotation = number(ext.Get("rotation"), "rotation");
  if (ext.Has("texCoord")) {
    const tinygltf::Value& v = ext.Get("texCoord");
    if (!v.IsInt() || v.Get<int>() < 0) fail(label, "texCoord must be an integer >= 0");
    texcoord = v.Get<int>();
  }
}

Texture MaterialReader::convert_texture(int index) {
  const tinygltf::Texture& gt = model_.textures[static_cast<std::size_t>(index)];
  std::string label = "texture" + quoted(gt.name) + " (" + std::to_string(index) + ")";
  if (gt.source == -1)
    fail(label, "has no image source (only PNG and JPEG images are supported)");
  const tinygltf::Image& image = at(model_.images, gt.source, "image", label);
  std::string image_label = "image" + quoted(image.name) + " (" + std::to_string(gt.source) + ")";
  int channels = image.component, bytes = image.bits / 8;
  std::size_t needed = static_cast<std::size_t>(std::max(image.width, 0)) *
                       static_cast<std::size_t>(std::max(image.height, 0)) *
                       static_cast<std::size_t>(std::max(channels, 0)) *
                       static_cast<std::size_t>(std::max(bytes, 0));
  if (image.width <= 0 || image.height <= 0 || channels < 1 || channels > 4 ||
      (bytes != 1 && bytes != 2) || image.image.size() < needed)
    fail(image_label, "has no decoded pixels (unsupported or broken image)");

  Texture tex;
  tex.width = image.width;
  tex.height = image.height;
  tex.texels.resize(static_cast<std::size_t>(tex.width) * static_cast<std::size_t>(tex.height));
  const unsigned char* src = image.image.data();
  auto channel = [&](std::size_t i) -> float {
    if (bytes == 1) return src[i] / 255.0f;
    std::uint16_t v;
    std::memcpy(&v, src + 2 * i, 2);
    return v / 65535.0f;
  };
  for (std::size_t p = 0; p < tex.texels.size(); ++p) {
    std::size_t i = p * static_cast<std::size_t>(channels);
    glm::vec4& t = tex.texels[p];
    switch (channels) {
      case 1:
        t = glm::vec4(glm::vec3(channel(i)), 1.0f);
        break;
      case 2:
        t = glm::vec4(glm::vec3(channel(i)), channel(i + 1));
        break;
      case 3:
        t = glm::vec4(channel(i), channel(i + 1), channel(i + 2), 1.0f);
        break;
      default:
        t = glm::vec4(channel(i), channel(i + 1), channel(i + 2), channel(i + 3));
        break;
    }
  }
  if (gt.sampler != -1) {
    const tinygltf::Sampler& s = at(model_.samplers, gt.sampler, "sampler", label);
    tex.wrap_s = wrap_mode(s.wrapS);
    tex.wrap_t = wrap_mode(s.wrapT);
    tex.nearest = s.magFilter == TINYGLTF_TEXTURE_FILTER_NEAREST;
  }
  return tex;
}

Wrap MaterialReader::wrap_mode(int gl) {
  switch (gl) {
    case TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE:
      return Wrap::ClampToEdge;
    case TINYGLTF_TEXTURE_WRAP_MIRRORED_REPEAT:
      return Wrap::MirroredRepeat;
    default:
      return Wrap::Repeat;
  }
}

}  // namespace dofcache::scene::gltf
