// Camera paths from glTF animations: the file is parsed again with tinygltf (images skipped), the
// chain of nodes from the scene root down to the camera's node is collected, and every channel of
// the chosen animation that targets a node of that chain becomes a track of that node.
#include <tiny_gltf.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

#include <glm/gtc/type_ptr.hpp>

#include "dofcache/core/error.h"
#include "dofcache/sequence/camera_path.h"

namespace dofcache::sequence {
namespace {

bool skip_image(tinygltf::Image*, const int, std::string*, std::string*, int, int,
                const unsigned char*, int, void*) {
  return true;  // only the node hierarchy and the animations matter here
}

class AnimationReader {
 public:
  AnimationReader(const tinygltf::Model& model, std::string name)
      : model_(model), name_(std::move(name)) {}

  CameraPath read(const scene::Camera& camera, const std::string& wanted) {
    const int cam_node = camera.node;
    if (cam_node < 0 || static_cast<std::size_t>(cam_node) >= model_.nodes.size())
      fail("camera '" + camera.name + "'",
           camera.synthesized ? "the scene has no camera, so nothing to animate"
                              : "is not a node of this file");
    std::vector<int> chain = ancestors(cam_node);
    const tinygltf::Animation& anim = pick(wanted, chain, camera);
    std::string anim_label = "animation" + quoted(anim.name) + " (" +
                             std::to_string(&anim - model_.animations.data()) + ")";

    CameraPath path;
    path.source = name_ + " " + anim_label;
    for (int n : chain) path.chain.push_back(rest_node(n));
    bool any = false;
    double start = 0.0, end = 0.0;
    for (std::size_t c = 0; c < anim.channels.size(); ++c) {
      const tinygltf::AnimationChannel& ch = anim.channels[c];
      auto it = std::find(chain.begin(), chain.end(), ch.target_node);
      if (it == chain.end()) continue;  // the scene is static: other nodes are not animated
      if (ch.target_path == "weights") continue;
      std::string label = anim_label + " channel " + std::to_string(c) + " (" + ch.target_path +
                          " of " + node_label(ch.target_node) + ")";
      if (ch.sampler < 0 || static_cast<std::size_t>(ch.sampler) >= anim.samplers.size())
        fail(label, "sampler index " + std::to_string(ch.sampler) + " is out of range");
      const tinygltf::AnimationSampler& smp = anim.samplers[static_cast<std::size_t>(ch.sampler)];
      AnimatedNode& node = path.chain[static_cast<std::size_t>(it - chain.begin())];
      if (node.matrix)
        fail(label, "the node has a matrix; glTF allows animating only nodes given as TRS");
      Interpolation mode =
          parse_interpolation(smp.interpolation.empty() ? "LINEAR" : smp.interpolation, label);
      std::vector<double> times = read_floats(smp.input, 1, label + " input");
      std::size_t expected = times.size() * (mode == Interpolation::CubicSpline ? 3 : 1);
      if (ch.target_path == "translation" || ch.target_path == "scale") {
        Track<glm::dvec3> track;
        track.interpolation = mode;
        track.times = times;
        std::vector<double> v = read_floats(smp.output, 3, label + " output");
        for (std::size_t i = 0; i + 2 < v.size(); i += 3)
          track.values.emplace_back(v[i], v[i + 1], v[i + 2]);
        check_count(track.values.size(), expected, label);
        track.validate(name_ + ": " + label);
        (ch.target_path == "translation" ? node.translation_track : node.scale_track) = track;
      } else if (ch.target_path == "rotation") {
        Track<glm::dquat> track;
        track.interpolation = mode;
        track.times = times;
        std::vector<double> v = read_floats(smp.output, 4, label + " output");
        for (std::size_t i = 0; i + 3 < v.size(); i += 4)  // glTF: (x, y, z, w)
          track.values.emplace_back(v[i + 3], v[i], v[i + 1], v[i + 2]);
        check_count(track.values.size(), expected, label);
        if (mode != Interpolation::CubicSpline)  // quantised rotations are only nearly unit
          for (glm::dquat& q : track.values) {
            double len = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
            if (len > 0.0) q = q * (1.0 / len);
          }
        track.validate(name_ + ": " + label);
        node.rotation_track = track;
      } else {
        fail(label, "unknown target path '" + ch.target_path + "'");
      }
      start = any ? std::min(start, times.front()) : times.front();
      end = any ? std::max(end, times.back()) : times.back();
      any = true;
    }
    if (!any) fail(anim_label, "has no translation, rotation or scale channel on the camera");
    path.start_time = start;
    path.end_time = end;
    return path;
  }

 private:
  [[noreturn]] void fail(const std::string& element, const std::string& problem) const {
    throw Error(name_ + ": " + element + ": " + problem);
  }
  static std::string quoted(const std::string& s) { return s.empty() ? "" : " '" + s + "'"; }
  std::string node_label(int n) const {
    return "node" + quoted(model_.nodes[static_cast<std::size_t>(n)].name) + " (" +
           std::to_string(n) + ")";
  }

  // Root first, ending with `node`.
  std::vector<int> ancestors(int node) const {
    std::vector<int> parent(model_.nodes.size(), -1);
    for (std::size_t p = 0; p < model_.nodes.size(); ++p)
      for (int c : model_.nodes[p].children)
        if (c >= 0 && static_cast<std::size_t>(c) < parent.size() && parent[c] == -1)
          parent[static_cast<std::size_t>(c)] = static_cast<int>(p);
    std::vector<int> chain;
    for (int n = node; n != -1; n = parent[static_cast<std::size_t>(n)]) {
      if (std::find(chain.begin(), chain.end(), n) != chain.end())
        fail(node_label(n), "the node hierarchy has a cycle");
      chain.insert(chain.begin(), n);
    }
    return chain;
  }

  const tinygltf::Animation& pick(const std::string& wanted, const std::vector<int>& chain,
                                  const scene::Camera& camera) const {
    const auto& anims = model_.animations;
    auto moves_camera = [&](const tinygltf::Animation& a) {
      for (const auto& ch : a.channels)
        if (std::find(chain.begin(), chain.end(), ch.target_node) != chain.end() &&
            ch.target_path != "weights")
          return true;
      return false;
    };
    if (!wanted.empty()) {
      for (const auto& a : anims)
        if (a.name == wanted) return a;
      char* end = nullptr;
      long index = std::strtol(wanted.c_str(), &end, 10);
      if (end && *end == '\0' && index >= 0 && static_cast<std::size_t>(index) < anims.size())
        return anims[static_cast<std::size_t>(index)];
      std::string names;
      for (std::size_t i = 0; i < anims.size(); ++i)
        names += (i ? ", " : "") +
                 (anims[i].name.empty() ? std::to_string(i) : "'" + anims[i].name + "'");
      fail("animation '" + wanted + "'",
           "not found (the file has " + (names.empty() ? std::string("no animations") : names) +
               ")");
    }
    for (const auto& a : anims)
      if (moves_camera(a)) return a;
    fail("camera '" + camera.name + "'",
         anims.empty() ? "the file has no animations (give a keyframe file with --path)"
                       : "no animation moves the camera's node or its parents");
  }

  AnimatedNode rest_node(int n) const {
    const tinygltf::Node& node = model_.nodes[static_cast<std::size_t>(n)];
    AnimatedNode a;
    if (!node.matrix.empty()) {
      if (node.matrix.size() != 16) fail(node_label(n), "matrix must have 16 numbers");
      a.matrix = glm::make_mat4(node.matrix.data());
      return a;
    }
    if (node.translation.size() == 3)
      a.translation = glm::dvec3(node.translation[0], node.translation[1], node.translation[2]);
    if (node.rotation.size() == 4) {
      glm::dquat q(node.rotation[3], node.rotation[0], node.rotation[1], node.rotation[2]);
      double len = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
      if (!(len > 0.0) || !std::isfinite(len))
        fail(node_label(n), "rotation is not a unit quaternion");
      a.rotation = q * (1.0 / len);
    }
    if (node.scale.size() == 3) a.scale = glm::dvec3(node.scale[0], node.scale[1], node.scale[2]);
    return a;
  }

  static void check_count(std::size_t got, std::size_t expected, const std::string& label) {
    if (got != expected)
      throw Error(label + ": output has " + std::to_string(got) + " elements, expected " +
                  std::to_string(expected));
  }

  // Reads an accessor of `components` floats per element (FLOAT, or normalised integers as glTF
  // allows for rotations), checking every index and byte range.
  std::vector<double> read_floats(int accessor_index, int components,
                                  const std::string& label) const {
    if (accessor_index < 0 || static_cast<std::size_t>(accessor_index) >= model_.accessors.size())
      fail(label, "accessor index " + std::to_string(accessor_index) + " is out of range");
    const tinygltf::Accessor& acc = model_.accessors[static_cast<std::size_t>(accessor_index)];
    std::string alabel = label + " accessor " + std::to_string(accessor_index);
    if (acc.sparse.isSparse) fail(alabel, "sparse accessors are not supported for animations");
    int type_components = tinygltf::GetNumComponentsInType(static_cast<std::uint32_t>(acc.type));
    if (type_components != components)
      fail(alabel, "must have " + std::to_string(components) + " components per element");
    int comp_size =
        tinygltf::GetComponentSizeInBytes(static_cast<std::uint32_t>(acc.componentType));
    bool is_float = acc.componentType == TINYGLTF_COMPONENT_TYPE_FLOAT;
    const int ct = acc.componentType;
    bool is_norm_int = acc.normalized && (ct == TINYGLTF_COMPONENT_TYPE_BYTE ||
                                          ct == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
                                          ct == TINYGLTF_COMPONENT_TYPE_SHORT ||
                                          ct == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT);
    if (!is_float && !(components == 4 && is_norm_int))
      fail(alabel, "must be FLOAT (or normalised integers for rotations)");
    std::vector<double> out(acc.count * static_cast<std::size_t>(components), 0.0);
    if (acc.bufferView < 0) return out;  // glTF: no buffer view means all zeros
    if (static_cast<std::size_t>(acc.bufferView) >= model_.bufferViews.size())
      fail(alabel, "buffer view index is out of range");
    const tinygltf::BufferView& view = model_.bufferViews[static_cast<std::size_t>(acc.bufferView)];
    if (view.buffer < 0 || static_cast<std::size_t>(view.buffer) >= model_.buffers.size())
      fail(alabel, "buffer index is out of range");
    const std::vector<unsigned char>& buffer =
        model_.buffers[static_cast<std::size_t>(view.buffer)].data;
    std::size_t elem = static_cast<std::size_t>(comp_size) * static_cast<std::size_t>(components);
    std::size_t stride = view.byteStride ? view.byteStride : elem;
    if (acc.count > 0) {
      std::size_t end_in_view = acc.byteOffset + (acc.count - 1) * stride + elem;
      if (view.byteOffset + view.byteLength > buffer.size() || end_in_view > view.byteLength)
        fail(alabel, "reads past the end of its buffer view or buffer");
    }
    const unsigned char* base = buffer.data() + view.byteOffset + acc.byteOffset;
    for (std::size_t i = 0; i < acc.count; ++i)
      for (int c = 0; c < components; ++c) {
        const unsigned char* p = base + i * stride + static_cast<std::size_t>(c) * comp_size;
        double v = 0.0;
        switch (acc.componentType) {
          case TINYGLTF_COMPONENT_TYPE_FLOAT: {
            float f;
            std::memcpy(&f, p, 4);
            v = f;
            break;
          }
          case TINYGLTF_COMPONENT_TYPE_BYTE:
            v = std::max(static_cast<signed char>(*p) / 127.0, -1.0);
            break;
          case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
            v = *p / 255.0;
            break;
          case TINYGLTF_COMPONENT_TYPE_SHORT: {
            std::int16_t s;
            std::memcpy(&s, p, 2);
            v = std::max(s / 32767.0, -1.0);
            break;
          }
          default: {
            std::uint16_t u;
            std::memcpy(&u, p, 2);
            v = u / 65535.0;
            break;
          }
        }
        out[i * static_cast<std::size_t>(components) + static_cast<std::size_t>(c)] = v;
      }
    return out;
  }

  const tinygltf::Model& model_;
  std::string name_;
};

}  // namespace

CameraPath load_gltf_camera_path(const std::string& gltf_file, const scene::Camera& camera,
                                 const std::string& animation) {
  std::ifstream in(gltf_file, std::ios::binary);
  if (!in) throw Error(gltf_file + ": cannot open file (" + std::strerror(errno) + ")");
  std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (data.size() > 0xffffffffu) throw Error(gltf_file + ": file is too large (over 4 GiB)");
  std::filesystem::path base = std::filesystem::path(gltf_file).parent_path();
  std::string base_dir = base.empty() ? std::string(".") : base.string();
  tinygltf::TinyGLTF parser;
  parser.SetImageLoader(skip_image, nullptr);
  tinygltf::Model model;
  std::string err, warn;
  bool ok;
  if (data.size() >= 4 && data.compare(0, 4, "glTF") == 0)
    ok = parser.LoadBinaryFromMemory(&model, &err, &warn,
                                     reinterpret_cast<const unsigned char*>(data.data()),
                                     static_cast<unsigned int>(data.size()), base_dir);
  else
    ok = parser.LoadASCIIFromString(&model, &err, &warn, data.data(),
                                    static_cast<unsigned int>(data.size()), base_dir);
  if (!ok) throw Error(gltf_file + ": " + (err.empty() ? "not a valid glTF file" : one_line(err)));
  return AnimationReader(model, gltf_file).read(camera, animation);
}

}  // namespace dofcache::sequence
