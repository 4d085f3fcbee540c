// Camera paths from glTF animations: the file is read through the scene module's glTF document
// layer (images skipped), the chain of nodes from the scene root down to the camera's node is
// collected with their rest transforms, and every channel of the chosen animation that targets a
// node of that chain becomes a track of that node.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string>

#include "dofcache/core/error.h"
#include "dofcache/core/file.h"
#include "dofcache/scene/gltf_document.h"
#include "dofcache/sequence/camera_path.h"

namespace dofcache::sequence {
namespace {

using scene::gltf::quoted;

class AnimationReader : scene::gltf::Document {
 public:
  AnimationReader(const tinygltf::Model& model, std::string name)
      : Document(model, std::move(name)) {}

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
      std::vector<double> times = read_floats(smp.input, TINYGLTF_TYPE_SCALAR, label + " input");
      std::size_t expected = times.size() * (mode == Interpolation::CubicSpline ? 3 : 1);
      if (ch.target_path == "translation" || ch.target_path == "scale") {
        Track<glm::dvec3> track;
        track.interpolation = mode;
        track.times = times;
        std::vector<double> v = read_floats(smp.output, TINYGLTF_TYPE_VEC3, label + " output");
        for (std::size_t i = 0; i + 2 < v.size(); i += 3)
          track.values.emplace_back(v[i], v[i + 1], v[i + 2]);
        check_count(track.values.size(), expected, label);
        track.validate(name_ + ": " + label);
        (ch.target_path == "translation" ? node.translation_track : node.scale_track) = track;
      } else if (ch.target_path == "rotation") {
        Track<glm::dquat> track;
        track.interpolation = mode;
        track.times = times;
        std::vector<double> v = read_floats(smp.output, TINYGLTF_TYPE_VEC4, label + " output");
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

  // The node's rest transform, validated as the scene loader validates it.
  AnimatedNode rest_node(int n) const {
    const scene::NodeTransform rest = node_transform(n);
    AnimatedNode a;
    a.matrix = rest.matrix;
    a.translation = rest.translation;
    a.rotation = rest.rotation;
    a.scale = rest.scale;
    return a;
  }

  static void check_count(std::size_t got, std::size_t expected, const std::string& label) {
    if (got != expected)
      throw Error(label + ": output has " + std::to_string(got) + " elements, expected " +
                  std::to_string(expected));
  }

  // Reads an accessor of `type` (SCALAR, VEC3 or VEC4) as doubles: FLOAT, or normalised integers
  // as glTF allows for rotations. Index and byte ranges are checked by the document layer.
  std::vector<double> read_floats(int accessor_index, int type, const std::string& label) const {
    const scene::gltf::AccessorView view = accessor(accessor_index, type, label);
    const int ct = view.component_type;
    bool is_float = ct == TINYGLTF_COMPONENT_TYPE_FLOAT;
    bool is_norm_int = view.normalized && (ct == TINYGLTF_COMPONENT_TYPE_BYTE ||
                                           ct == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
                                           ct == TINYGLTF_COMPONENT_TYPE_SHORT ||
                                           ct == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT);
    if (!is_float && !(type == TINYGLTF_TYPE_VEC4 && is_norm_int))
      fail(label + " accessor " + std::to_string(accessor_index),
           "must be FLOAT (or normalised integers for rotations)");
    const auto components = static_cast<std::size_t>(view.components);
    std::vector<double> out(view.count * components, 0.0);
    for (std::size_t i = 0; i < view.count; ++i)
      for (std::size_t c = 0; c < components; ++c)
        out[i * components + c] = view.component<double>(i, static_cast<int>(c));
    return out;
  }
};

}  // namespace

CameraPath load_gltf_camera_path(const std::string& gltf_file, const scene::Camera& camera,
                                 const std::string& animation) {
  // Only the node hierarchy and the animations matter here: images are not decoded.
  scene::gltf::Parsed parsed =
      scene::gltf::parse(read_file(gltf_file), gltf_file,
                         scene::gltf::base_dir_of(gltf_file), /*load_images=*/false);
  return AnimationReader(parsed.model, gltf_file).read(camera, animation);
}

}  // namespace dofcache::sequence
