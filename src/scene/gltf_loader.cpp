// glTF 2.0 -> Scene. tinygltf parses the JSON/GLB, decodes buffers and images; everything the
// renderer relies on (indices, accessor ranges, finite positions, non-degenerate triangles) is
// validated here, because tinygltf leaves most of it unchecked (and indices at -1 when absent).
#include "dofcache/scene/gltf_loader.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <cstring>
#include <map>
#include <optional>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_inverse.hpp>
#include <glm/mat3x3.hpp>

#include "dofcache/core/content_hash.h"
#include "dofcache/core/error.h"
#include "dofcache/core/file.h"
#include "dofcache/core/rng.h"
#include "dofcache/scene/gltf_document.h"
#include "dofcache/scene/gltf_materials.h"
#include "dofcache/scene/tangents.h"
#include "dofcache/scene/transform.h"

namespace dofcache::scene {
namespace {

using gltf::AccessorView;
using gltf::quoted;

constexpr const char* kLightsExt = "KHR_lights_punctual";
using gltf::kEmissiveStrengthExt;
using gltf::kTextureTransformExt;
constexpr const char* kDracoExtension = "KHR_draco_mesh_compression";

// Extensions the loader implements; a file that requires any other one is rejected rather than
// rendered wrongly.
bool understood_extension(const std::string& name) {
  return name == kLightsExt || name == kEmissiveStrengthExt || name == kTextureTransformExt ||
         name == "KHR_mesh_quantization";
}

bool finite(glm::vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

// ----------------------------------------------------------------------------------------------
// Content hash: a stable 64-bit identity of what the renderer sees.

// Seed of the scene hash ("dofcach"). Floats hash by their own 32-bit patterns
// (ContentHasher::add_float32), as they always have: the value identifies scenes in cache files.
constexpr std::uint64_t kSceneHashSeed = 0x646f6663616368ULL;

void add(ContentHasher& h, float f) { h.add_float32(f); }
void add(ContentHasher& h, glm::vec2 v) { add(h, v.x), add(h, v.y); }
void add(ContentHasher& h, glm::vec3 v) { add(h, v.x), add(h, v.y), add(h, v.z); }
void add(ContentHasher& h, glm::vec4 v) { add(h, v.x), add(h, v.y), add(h, v.z), add(h, v.w); }

std::uint64_t content_hash(const Scene& s) {
  ContentHasher h(kSceneHashSeed);
  h.add(static_cast<std::uint64_t>(s.mesh.positions.size()));
  for (glm::vec3 p : s.mesh.positions) add(h, p);
  for (glm::vec3 n : s.mesh.normals) add(h, n);
  h.add(static_cast<std::uint64_t>(s.mesh.uv0.size()));
  for (glm::vec2 t : s.mesh.uv0) add(h, t);
  h.add(static_cast<std::uint64_t>(s.mesh.uv1.size()));
  for (glm::vec2 t : s.mesh.uv1) add(h, t);
  h.add(static_cast<std::uint64_t>(s.mesh.triangles.size()));
  for (std::size_t i = 0; i < s.mesh.triangles.size(); ++i) {
    const glm::uvec3& t = s.mesh.triangles[i];
    h.add((static_cast<std::uint64_t>(t.x) << 32) | t.y);
    h.add((static_cast<std::uint64_t>(t.z) << 32) | s.mesh.triangle_material[i]);
  }
  h.add(static_cast<std::uint64_t>(s.materials.size()));
  for (const Material& m : s.materials) {
    h.add(m.name);
    add(h, m.base_color);
    add(h, m.metallic), add(h, m.roughness);
    add(h, m.emissive);
    for (const TextureRef* r :
         {&m.base_color_texture, &m.metallic_roughness_texture, &m.emissive_texture})
      h.add((static_cast<std::uint64_t>(static_cast<std::uint32_t>(r->index)) << 8) |
            static_cast<std::uint64_t>(r->texcoord));
    h.add(static_cast<std::uint64_t>(m.double_sided));
  }
  // What later glTF features added is hashed only where a scene uses it, so that scenes without
  // them keep the identity their cache files were written under.
  for (const Material& m : s.materials) {
    bool plain = m.alpha_mode == AlphaMode::Opaque && m.normal_texture.index < 0;
    for (const TextureRef* r : {&m.base_color_texture, &m.metallic_roughness_texture,
                                &m.emissive_texture, &m.normal_texture})
      plain = plain && !r->has_transform();
    if (plain) continue;
    h.add(static_cast<std::uint64_t>(m.alpha_mode));
    add(h, m.alpha_cutoff), add(h, m.normal_scale);
    for (const TextureRef* r : {&m.base_color_texture, &m.metallic_roughness_texture,
                                &m.emissive_texture, &m.normal_texture}) {
      h.add((static_cast<std::uint64_t>(static_cast<std::uint32_t>(r->index)) << 8) |
            static_cast<std::uint64_t>(r->texcoord));
      add(h, r->offset), add(h, r->scale), add(h, r->rotation);
    }
  }
  if (!s.mesh.colors.empty()) {
    h.add(std::string("COLOR_0"));
    for (glm::vec4 c : s.mesh.colors) add(h, c);
  }
  if (!s.mesh.tangents.empty()) {
    h.add(std::string("TANGENT"));
    for (glm::vec4 t : s.mesh.tangents) add(h, t);
  }
  h.add(static_cast<std::uint64_t>(s.textures.size()));
  for (const Texture& t : s.textures) {
    h.add((static_cast<std::uint64_t>(t.width) << 32) | static_cast<std::uint32_t>(t.height));
    h.add((static_cast<std::uint64_t>(t.wrap_s) << 16) |
          (static_cast<std::uint64_t>(t.wrap_t) << 8) | static_cast<std::uint64_t>(t.nearest));
    for (glm::vec4 v : t.texels) add(h, v);
  }
  h.add(static_cast<std::uint64_t>(s.lights.size()));
  for (const PunctualLight& l : s.lights) {
    h.add(static_cast<std::uint64_t>(l.type));
    add(h, l.position), add(h, l.direction), add(h, l.intensity);
    add(h, l.range), add(h, l.inner_cone), add(h, l.outer_cone);
  }
  return h.value();
}

// ----------------------------------------------------------------------------------------------

// The scene loader is a reader of the glTF document (gltf_document.h): parsing, labels, index
// checks, accessors and node transforms are the document layer's.
class Loader : gltf::Document {
 public:
  Loader(const tinygltf::Model& model, std::string name, const LoadOptions& options)
      : Document(model, std::move(name)), options_(options) {}

  Scene load() {
    check_extensions();
    std::vector<int> roots = root_nodes();
    scene_.source = name_;
    // Every glTF material is converted (Scene::materials keeps the glTF indices); the default
    // material, if a primitive needs it, is appended after them.
    for (std::size_t i = 0; i < model_.materials.size(); ++i)
      scene_.materials.push_back(materials_.material(static_cast<int>(i)));
    visit_nodes(roots);
    if (scene_.mesh.triangles.empty())
      throw Error(name_ + ": no triangle geometry in " + scene_label_ +
                  " (no node with a mesh of triangles)");
    finish_mesh();
    build_emitters();
    if (scene_.cameras.empty()) synthesize_camera();
    scene_.content_hash = content_hash(scene_);
    return std::move(scene_);
  }

 private:
  void warn(const std::string& element, const std::string& note) {
    scene_.warnings.push_back(one_line(name_ + ": " + element + ": " + note));
  }

  void check_extensions() {
    for (const std::string& ext : model_.extensionsRequired)
      if (!understood_extension(ext)) fail("extensionsRequired", "unsupported extension " + ext);
  }

  // Root nodes of the chosen scene: LoadOptions::scene_index, else the file's default scene,
  // else scene 0; a file without scenes shows every node that is nobody's child.
  std::vector<int> root_nodes() {
    int count = static_cast<int>(model_.scenes.size());
    int index = options_.scene_index;
    if (index < -1 || index >= count)
      fail("scene " + std::to_string(index), "scene index out of range (the file has " +
                                                 std::to_string(count) + " scene" +
                                                 (count == 1 ? ")" : "s)"));
    if (index < 0)
      index = model_.defaultScene >= 0 && model_.defaultScene < count ? model_.defaultScene : 0;
    if (count == 0) {
      scene_label_ = "the file";
      std::vector<bool> is_child(model_.nodes.size(), false);
      for (std::size_t n = 0; n < model_.nodes.size(); ++n)
        for (int c : model_.nodes[n].children)
          if (c >= 0 && static_cast<std::size_t>(c) < is_child.size())
            is_child[static_cast<std::size_t>(c)] = true;
      std::vector<int> roots;
      for (std::size_t n = 0; n < model_.nodes.size(); ++n)
        if (!is_child[n]) roots.push_back(static_cast<int>(n));
      return roots;
    }
    const tinygltf::Scene& s = model_.scenes[static_cast<std::size_t>(index)];
    scene_label_ = "scene" + quoted(s.name) + " (" + std::to_string(index) + ")";
    for (int n : s.nodes) at(model_.nodes, n, "node", scene_label_);
    return s.nodes;
  }

  glm::dmat4 local_matrix(int n) const { return node_transform(n).local(); }

  // A node waiting to be visited: its parent's world matrix and its depth below the root.
  struct PendingNode {
    int node, parent;
    glm::dmat4 parent_world;
    std::size_t depth;
  };

  // Every node below `roots`, depth first: each after its parent and before its next sibling
  // (the order meshes are appended in). An explicit stack rather than recursion, so that a deep
  // hierarchy is bounded by the depth limit alone, not by the call stack.
  void visit_nodes(const std::vector<int>& roots) {
    reached_.assign(model_.nodes.size(), false);
    parent_.assign(model_.nodes.size(), -1);
    std::vector<PendingNode> pending;
    for (auto r = roots.rbegin(); r != roots.rend(); ++r)
      pending.push_back({*r, -1, glm::dmat4(1.0), 0});
    while (!pending.empty()) {
      PendingNode p = pending.back();
      pending.pop_back();
      visit(p, pending);
    }
  }

  bool is_ancestor(int candidate, int node) const {
    for (int a = node; a != -1; a = parent_[static_cast<std::size_t>(a)])
      if (a == candidate) return true;
    return false;
  }

  void visit(const PendingNode& p, std::vector<PendingNode>& pending) {
    const int n = p.node;
    // glTF node hierarchies are disjoint trees (glTF 3.5.3); a node shared by several parents
    // would multiply everything below it, exponentially in the depth of such sharing.
    if (reached_[static_cast<std::size_t>(n)])
      fail(node_label(n), is_ancestor(n, p.parent)
                              ? "the node hierarchy has a cycle"
                              : "is reached twice (a child of two nodes, or listed twice as a "
                                "root); glTF node hierarchies must be trees");
    reached_[static_cast<std::size_t>(n)] = true;
    parent_[static_cast<std::size_t>(n)] = p.parent;
    if (p.depth >= static_cast<std::size_t>(std::max(options_.limits.max_node_depth, 1)))
      fail(node_label(n), "is deeper than the node depth limit (" +
                              std::to_string(options_.limits.max_node_depth) +
                              "; raise it with --max-node-depth)");
    const tinygltf::Node& node = model_.nodes[static_cast<std::size_t>(n)];
    glm::dmat4 world = p.parent_world * local_matrix(n);
    if (node.mesh != -1) {
      at(model_.meshes, node.mesh, "mesh", node_label(n));
      add_mesh(n, node.mesh, world);
    }
    if (node.camera != -1) {
      at(model_.cameras, node.camera, "camera", node_label(n));
      add_camera(n, world);
    }
    auto light = node.extensions.find(kLightsExt);
    if (light != node.extensions.end()) add_light(n, light->second, world);
    for (int child : node.children) at(model_.nodes, child, "node", node_label(n));
    for (auto c = node.children.rbegin(); c != node.children.rend(); ++c)
      pending.push_back({*c, n, world, p.depth + 1});
  }

  // -- meshes

  void add_mesh(int node, int mesh_index, const glm::dmat4& world) {
    const tinygltf::Mesh& mesh = model_.meshes[static_cast<std::size_t>(mesh_index)];
    glm::dmat3 linear(world);
    glm::dmat3 normal_matrix = glm::inverseTranspose(linear);
    // A mirroring transform flips the winding; glTF says the determinant decides the front face.
    bool mirrored = glm::determinant(linear) < 0.0;
    for (std::size_t p = 0; p < mesh.primitives.size(); ++p)
      add_primitive(node, mesh_index, p, world, normal_matrix, mirrored);
  }

  void add_primitive(int node, int mesh_index, std::size_t p, const glm::dmat4& world,
                     const glm::dmat3& normal_matrix, bool mirrored) {
    const tinygltf::Primitive& prim =
        model_.meshes[static_cast<std::size_t>(mesh_index)].primitives[p];
    std::string label = mesh_label(mesh_index) + " primitive " + std::to_string(p);
    int mode = prim.mode == -1 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
    if (mode == TINYGLTF_MODE_POINTS || mode == TINYGLTF_MODE_LINE ||
        mode == TINYGLTF_MODE_LINE_LOOP || mode == TINYGLTF_MODE_LINE_STRIP) {
      warn(label, "points and lines are not rendered; primitive skipped");
      return;
    }
    if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP &&
        mode != TINYGLTF_MODE_TRIANGLE_FAN)
      fail(label, "unknown primitive mode " + std::to_string(mode));

    auto attribute = [&](const char* name) {
      auto it = prim.attributes.find(name);
      return it == prim.attributes.end() ? -1 : it->second;
    };
    int pos_acc = attribute("POSITION");
    if (pos_acc < 0) fail(label, "has no POSITION attribute");
    // Draco (extensionsUsed only; a file requiring it was refused): the uncompressed attributes
    // are the fallback, which a file need not have. Debian's Draco library is not used to decode:
    // it carries its own copy of tinygltf, whose symbols clash with tinygltf's (docs/scenes.md).
    if (prim.extensions.count(kDracoExtension) && model_.accessors.size() > std::size_t(pos_acc) &&
        model_.accessors[std::size_t(pos_acc)].bufferView == -1 &&
        !model_.accessors[std::size_t(pos_acc)].sparse.isSparse)
      fail(label, std::string("is compressed with ") + kDracoExtension +
                      ", which is not supported, and has no uncompressed fallback");
    auto view = [&](const char* name, int a, int type) {
      return accessor(a, type, label + " " + name);
    };
    AccessorView pos = view("POSITION", pos_acc, TINYGLTF_TYPE_VEC3);
    std::size_t vertex_count = pos.count;
    std::optional<AccessorView> nrm, uv[2];
    if (int a = attribute("NORMAL"); a >= 0) nrm = view("NORMAL", a, TINYGLTF_TYPE_VEC3);
    if (int a = attribute("TEXCOORD_0"); a >= 0) uv[0] = view("TEXCOORD_0", a, TINYGLTF_TYPE_VEC2);
    if (int a = attribute("TEXCOORD_1"); a >= 0) uv[1] = view("TEXCOORD_1", a, TINYGLTF_TYPE_VEC2);
    VertexAttributes extra;
    extra.linear = glm::dmat3(world);
    extra.mirrored = mirrored;
    if (int a = attribute("COLOR_0"); a >= 0) {
      const std::string user = label + " COLOR_0";
      int type = accessor_type(a, user);
      extra.color = view("COLOR_0", a, type == TINYGLTF_TYPE_VEC3 ? type : TINYGLTF_TYPE_VEC4);
      int ct = extra.color->component_type;
      if (!(ct == TINYGLTF_COMPONENT_TYPE_FLOAT ||
            (extra.color->normalized && (ct == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
                                         ct == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT))))
        fail(user, "must be FLOAT or normalized UNSIGNED_BYTE or UNSIGNED_SHORT");
    }
    std::uint32_t material = material_index(prim.material, label);
    const Material& mat = scene_.materials[material];
    const bool wants_tangents = mat.normal_texture.index >= 0;
    if (int a = attribute("TANGENT"); a >= 0) {
      const std::string user = label + " TANGENT";
      AccessorView t = view("TANGENT", a, TINYGLTF_TYPE_VEC4);
      if (t.component_type != TINYGLTF_COMPONENT_TYPE_FLOAT && !t.normalized)
        fail(user, "must be FLOAT or normalized BYTE or SHORT");
      if (wants_tangents) extra.tangent = t;
    }
    for (const auto* v : {&nrm, &uv[0], &uv[1], &extra.color, &extra.tangent})
      if (*v && (*v)->count != vertex_count)
        fail(label, "attribute counts differ (" + std::to_string((*v)->count) + " vs " +
                        std::to_string(vertex_count) + " positions)");

    // Vertex indices of the primitive, as triangles in the primitive's own numbering.
    std::optional<AccessorView> idx;
    if (prim.indices != -1) {
      idx = accessor(prim.indices, TINYGLTF_TYPE_SCALAR, label + " indices");
      if (idx->component_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
          idx->component_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
          idx->component_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
        fail(label + " indices", "index componentType must be an unsigned integer type");
    }
    reserve_budget(label, vertex_count, idx ? idx->count : vertex_count, mode);
    std::vector<std::uint32_t> order;
    if (idx) {
      order.resize(idx->count);
      for (std::size_t i = 0; i < idx->count; ++i) {
        order[i] = idx->index(i);
        if (order[i] >= vertex_count)
          fail(label + " indices", "index " + std::to_string(order[i]) + " at position " +
                                       std::to_string(i) + " is out of range (" +
                                       std::to_string(vertex_count) + " vertices)");
      }
    } else {
      order.resize(vertex_count);
      for (std::size_t i = 0; i < vertex_count; ++i) order[i] = static_cast<std::uint32_t>(i);
    }
    std::vector<glm::uvec3> tris;
    if (mode == TINYGLTF_MODE_TRIANGLES) {
      if (order.size() % 3 != 0)
        warn(label, std::to_string(order.size() % 3) + " trailing index(es) ignored");
      for (std::size_t i = 0; i + 2 < order.size(); i += 3)
        tris.emplace_back(order[i], order[i + 1], order[i + 2]);
    } else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
      for (std::size_t i = 0; i + 2 < order.size(); ++i)  // keep every triangle's orientation
        tris.emplace_back(order[i], order[i + 1 + i % 2], order[i + 2 - i % 2]);
    } else {
      for (std::size_t i = 1; i + 1 < order.size(); ++i)
        tris.emplace_back(order[i], order[i + 1], order[0]);
    }
    if (tris.empty()) {
      warn(label, "has no triangles");
      return;
    }

    // World-space vertices.
    std::vector<glm::vec3> positions(vertex_count), normals;
    for (std::size_t i = 0; i < vertex_count; ++i) {
      glm::dvec3 local(pos.component<float>(i, 0), pos.component<float>(i, 1),
                       pos.component<float>(i, 2));
      if (!std::isfinite(local.x) || !std::isfinite(local.y) || !std::isfinite(local.z))
        fail(label + " POSITION", "vertex " + std::to_string(i) + " is not finite (NaN or Inf)");
      positions[i] = glm::vec3(world * glm::dvec4(local, 1.0));
      if (!finite(positions[i]))
        fail(label + " POSITION", "vertex " + std::to_string(i) + " is not finite after the " +
                                      node_label(node) + " transform");
    }
    if (nrm) {
      normals.resize(vertex_count);
      for (std::size_t i = 0; i < vertex_count; ++i) {
        glm::dvec3 n = normal_matrix * glm::dvec3(nrm->component<float>(i, 0),
                                                  nrm->component<float>(i, 1),
                                                  nrm->component<float>(i, 2));
        double len = glm::length(n);
        // Zero or broken normals are repaired from the faces below (marked by a zero vector).
        normals[i] = len > 0.0 && std::isfinite(len) ? glm::vec3(n / len) : glm::vec3(0.0f);
      }
    }

    // Validate triangles (world space) and append.
    bool strip_or_fan = mode != TINYGLTF_MODE_TRIANGLES;
    Mesh& out = scene_.mesh;
    auto base = static_cast<std::uint32_t>(out.positions.size());
    std::vector<glm::uvec3> kept;
    kept.reserve(tris.size());
    const std::size_t first_triangle = out.triangles.size();
    for (std::size_t t = 0; t < tris.size(); ++t) {
      glm::uvec3 tri = tris[t];
      if (mirrored) std::swap(tri.y, tri.z);
      glm::dvec3 p0(positions[tri.x]), p1(positions[tri.y]), p2(positions[tri.z]);
      glm::dvec3 e0 = p1 - p0, e1 = p2 - p0, e2 = p2 - p1;
      double cross = glm::length(glm::cross(e0, e1));
      double longest = std::max({glm::dot(e0, e0), glm::dot(e1, e1), glm::dot(e2, e2)});
      if (!(cross > 1e-10 * longest) || longest == 0.0) {
        if (strip_or_fan) continue;  // degenerate stitching triangles are normal in strips
        fail(label, "triangle " + std::to_string(t) + " has zero area (vertices " +
                        std::to_string(tris[t].x) + ", " + std::to_string(tris[t].y) + ", " +
                        std::to_string(tris[t].z) + ")");
      }
      kept.push_back(tri);
    }
    if (nrm) {
      // Shared vertices, the primitive's own normals.
      for (glm::uvec3 tri : kept) {
        glm::vec3 face = glm::cross(positions[tri.y] - positions[tri.x],  // area-weighted
                                    positions[tri.z] - positions[tri.x]);
        for (std::uint32_t v : {tri.x, tri.y, tri.z})
          if (normals[v] == glm::vec3(0.0f)) repaired_.emplace_back(base + v, face);
      }
      for (std::size_t i = 0; i < vertex_count; ++i) {
        out.positions.push_back(positions[i]);
        out.normals.push_back(normals[i]);
        push_uvs(uv, i);
        push_attributes(extra, i);
      }
      for (glm::uvec3 tri : kept) push_triangle(tri + glm::uvec3(base), material, node);
    } else {
      // No NORMAL: flat shading, so every triangle gets its own three vertices.
      for (glm::uvec3 tri : kept) {
        glm::dvec3 p0(positions[tri.x]), p1(positions[tri.y]), p2(positions[tri.z]);
        glm::vec3 face(glm::normalize(glm::cross(p1 - p0, p2 - p0)));  // double: tiny triangles
        auto first = static_cast<std::uint32_t>(out.positions.size());
        for (std::uint32_t v : {tri.x, tri.y, tri.z}) {
          out.positions.push_back(positions[v]);
          out.normals.push_back(face);
          push_uvs(uv, v);
          push_attributes(extra, v);
        }
        push_triangle(glm::uvec3(first, first + 1, first + 2), material, node);
      }
    }
    if (wants_tangents && !extra.tangent) {
      const int set = mat.normal_texture.texcoord;
      if (!uv[set]) {
        warn(label, "the normal texture needs TEXCOORD_" + std::to_string(set) +
                        ", which the primitive lacks; normal texture ignored");
      } else {
        // The normal texture's x axis runs along its own u, the one KHR_texture_transform gives:
        // tangents come from the transformed coordinates (a rotation turns them, a mirror flips
        // the handedness), so a transformed map shades as it would baked without the transform.
        const TextureRef& ref = mat.normal_texture;
        std::vector<glm::vec2> transformed;
        if (ref.has_transform()) {
          transformed = set == 0 ? out.uv0 : out.uv1;
          for (std::size_t i = base; i < transformed.size(); ++i)
            transformed[i] = ref.apply(transformed[i]);
        }
        std::vector<glm::vec4> t = generate_tangents(
            out.positions, out.normals,
            ref.has_transform() ? transformed : set == 0 ? out.uv0 : out.uv1, out.triangles,
            base, first_triangle);
        std::copy(t.begin(), t.end(), out.tangents.end() - static_cast<std::ptrdiff_t>(t.size()));
        has_tangents_ = true;
      }
    }
  }

  // A primitive's optional per-vertex attributes besides normals and texture coordinates.
  struct VertexAttributes {
    std::optional<AccessorView> color, tangent;
    glm::dmat3 linear{1.0};  // the node's: tangents are directions on the surface
    bool mirrored = false;   // a mirroring transform flips the bitangent: w changes sign
  };

  // Appends vertex v's COLOR_0 and TANGENT (zero where the primitive has none; finish_mesh drops
  // the arrays if no primitive has any).
  void push_attributes(const VertexAttributes& a, std::size_t v) {
    Mesh& m = scene_.mesh;
    glm::vec4 color(1.0f);
    if (a.color) {
      has_colors_ = true;
      for (int c = 0; c < a.color->components; ++c) color[c] = a.color->component<float>(v, c);
      if (!(color.r >= 0.0f && color.g >= 0.0f && color.b >= 0.0f && color.a >= 0.0f) ||
          !finite(glm::vec3(color)) || !std::isfinite(color.a))
        color = glm::clamp(glm::vec4(std::isfinite(color.r) ? color.r : 0.0f,
                                     std::isfinite(color.g) ? color.g : 0.0f,
                                     std::isfinite(color.b) ? color.b : 0.0f,
                                     std::isfinite(color.a) ? color.a : 1.0f),
                           0.0f, 1e30f);
    }
    m.colors.push_back(color);
    glm::vec4 tangent(0.0f);
    if (a.tangent) {
      has_tangents_ = true;
      glm::dvec3 t = a.linear * glm::dvec3(a.tangent->component<double>(v, 0),
                                           a.tangent->component<double>(v, 1),
                                           a.tangent->component<double>(v, 2));
      double len = glm::length(t);
      float w = a.tangent->component<float>(v, 3) < 0.0f ? -1.0f : 1.0f;
      if (a.mirrored) w = -w;
      // A zero or broken tangent leaves the point without a normal texture frame.
      if (len > 0.0 && std::isfinite(len)) tangent = glm::vec4(glm::vec3(t / len), w);
    }
    m.tangents.push_back(tangent);
  }

  // Counts a primitive's vertices and triangles (at most: before degenerate ones are dropped)
  // against the limits before anything is allocated for it. A primitive without NORMAL gets
  // three vertices per triangle.
  void reserve_budget(const std::string& label, std::uint64_t vertices, std::uint64_t indices,
                      int mode) {
    std::uint64_t triangles = mode == TINYGLTF_MODE_TRIANGLES ? indices / 3
                              : indices >= 2                  ? indices - 2
                                                              : 0;
    vertices = std::max(vertices, 3 * triangles);
    const LoadLimits& limits = options_.limits;
    if (vertices > limits.max_vertices - std::min(vertices_, limits.max_vertices))
      fail(label, "the scene would exceed the vertex limit (" +
                      std::to_string(limits.max_vertices) + "; raise it with --max-vertices)");
    if (triangles > limits.max_triangles - std::min(triangles_, limits.max_triangles))
      fail(label, "the scene would exceed the triangle limit (" +
                      std::to_string(limits.max_triangles) + "; raise it with --max-triangles)");
    vertices_ += vertices;
    triangles_ += triangles;
  }

  void push_uvs(const std::optional<AccessorView> (&uv)[2], std::size_t v) {
    for (int set = 0; set < 2; ++set) {
      std::vector<glm::vec2>& dst = set == 0 ? scene_.mesh.uv0 : scene_.mesh.uv1;
      if (uv[set]) {
        has_uv_[set] = true;
        dst.emplace_back(uv[set]->component<float>(v, 0), uv[set]->component<float>(v, 1));
      } else {
        dst.emplace_back(0.0f);
      }
    }
  }

  void push_triangle(glm::uvec3 tri, std::uint32_t material, int node) {
    scene_.mesh.triangles.push_back(tri);
    scene_.mesh.triangle_material.push_back(material);
    scene_.mesh.triangle_object.push_back(static_cast<std::uint32_t>(node));
  }

  void finish_mesh() {
    Mesh& m = scene_.mesh;
    // Vertices whose NORMAL was zero or broken get the (area-weighted) mean of their faces.
    std::map<std::uint32_t, glm::vec3> sums;
    for (auto& [v, face] : repaired_) sums[v] += face;
    for (auto& [v, sum] : sums)
      m.normals[v] = glm::length(sum) > 0.0f ? glm::normalize(sum) : glm::vec3(0, 0, 1);
    // Arrays no primitive filled are freed, not just emptied, and the others lose the slack of
    // their growth: on a scene of millions of triangles, the attributes filled with defaults
    // and the doubling of push_back held about as much memory as the data (docs/scenes.md,
    // "Scale").
    if (!has_uv_[0]) std::vector<glm::vec2>().swap(m.uv0);
    if (!has_uv_[1]) std::vector<glm::vec2>().swap(m.uv1);
    if (!has_colors_) std::vector<glm::vec4>().swap(m.colors);
    if (!has_tangents_) std::vector<glm::vec4>().swap(m.tangents);
    fit(m.normals), fit(m.uv0), fit(m.uv1), fit(m.colors), fit(m.tangents);
    fit(m.triangles), fit(m.triangle_material), fit(m.triangle_object);
    for (glm::vec3 p : m.positions) scene_.bounds.extend(p);
    // Embree reads vertex buffers with 16-byte loads: keep (initialised) room for one more float
    // after the last vertex so the accelerator can share this buffer (see accel.cpp).
    m.positions.emplace_back(0.0f);
    m.positions.pop_back();
    if (m.positions.capacity() > m.positions.size() + m.positions.size() / 64 + 1) {
      std::vector<glm::vec3> fitted;
      fitted.reserve(m.positions.size() + 1);
      fitted = m.positions;  // keeps the reserved capacity (no reallocation: it fits)
      fitted.emplace_back(0.0f);
      fitted.pop_back();
      m.positions.swap(fitted);
    }
  }

  // Drops a vector's unused capacity when it is more than a little (a copy costs time).
  template <class T>
  static void fit(std::vector<T>& v) {
    if (v.capacity() > v.size() + v.size() / 64) v.shrink_to_fit();
  }

  // -- materials and textures

  std::uint32_t material_index(int index, const std::string& user) {
    if (index == -1) {
      if (default_material_ < 0) {
        // glTF's default material: every property at its default (white, metallic 1, rough 1).
        Material m;
        m.name = "default";
        default_material_ = static_cast<int>(scene_.materials.size());
        scene_.materials.push_back(m);
      }
      return static_cast<std::uint32_t>(default_material_);
    }
    at(model_.materials, index, "material", user);
    return static_cast<std::uint32_t>(index);
  }

  // -- lights and cameras

  void add_light(int n, const tinygltf::Value& ext, const glm::dmat4& world) {
    std::string label = node_label(n) + " " + kLightsExt;
    const tinygltf::Value& index_value = ext.Get("light");
    if (!index_value.IsNumber()) fail(label, "has no light index");
    const tinygltf::Light& gl = at(model_.lights, index_value.GetNumberAsInt(), "light", label);
    PunctualLight l;
    if (gl.type == "point")
      l.type = PunctualLight::Type::Point;
    else if (gl.type == "spot")
      l.type = PunctualLight::Type::Spot;
    else if (gl.type == "directional")
      l.type = PunctualLight::Type::Directional;
    else
      fail(label, "unknown light type '" + gl.type + "'");
    glm::vec3 color(1.0f);
    if (gl.color.size() == 3) color = glm::vec3(gl.color[0], gl.color[1], gl.color[2]);
    l.intensity = color * static_cast<float>(gl.intensity);
    l.range = static_cast<float>(gl.range);
    l.position = glm::vec3(world * glm::dvec4(0.0, 0.0, 0.0, 1.0));
    glm::dvec3 dir = glm::dmat3(world) * glm::dvec3(0.0, 0.0, -1.0);  // lights shine down -Z
    double len = glm::length(dir);
    if (!(len > 0.0)) fail(label, "the node transform collapses the light direction");
    l.direction = glm::vec3(dir / len);
    if (l.type == PunctualLight::Type::Spot) {
      l.inner_cone = static_cast<float>(gl.spot.innerConeAngle);
      l.outer_cone = static_cast<float>(gl.spot.outerConeAngle);
      if (!(l.inner_cone >= 0.0f && l.inner_cone < l.outer_cone && l.outer_cone <= 1.5707964f))
        fail(label, "spot cone angles must satisfy 0 <= inner < outer <= pi/2");
    }
    if (!finite(l.intensity) || !(l.range >= 0.0f) || !std::isfinite(l.range))
      fail(label, "intensity and range must be finite, range >= 0");
    scene_.lights.push_back(l);
  }

  void add_camera(int n, const glm::dmat4& world) {
    const tinygltf::Node& node = model_.nodes[static_cast<std::size_t>(n)];
    const tinygltf::Camera& gc = model_.cameras[static_cast<std::size_t>(node.camera)];
    std::string label = node_label(n) + " camera " + std::to_string(node.camera);
    if (gc.type != "perspective") {
      warn(label, "only perspective cameras are used; '" + gc.type + "' camera skipped");
      return;
    }
    Camera cam;
    cam.name = !node.name.empty() ? node.name
               : !gc.name.empty() ? gc.name
                                  : "camera" + std::to_string(scene_.cameras.size());
    cam.node = n;
    const auto& p = gc.perspective;
    if (!(p.yfov > 0.0 && p.yfov < 3.14159)) fail(label, "yfov must be in (0, pi)");
    cam.yfov = static_cast<float>(p.yfov);
    if (p.aspectRatio > 0.0 && std::isfinite(p.aspectRatio))
      cam.aspect_ratio = static_cast<float>(p.aspectRatio);
    if (p.znear > 0.0 && std::isfinite(p.znear)) cam.znear = static_cast<float>(p.znear);

    // Rigid part of the world matrix (glTF cameras ignore scale): transform.h.
    glm::dmat4 frame;
    if (const char* problem = rigid_camera_frame(world, frame))
      fail(label, std::string("the node transform ") + problem);
    cam.camera_to_world = glm::mat4(frame);

    // Lens settings: the node's extras.lens wins key by key over the camera object's, which wins
    // over the draft EXT_camera_physical extension's values.
    if (auto it = gc.extensions.find("EXT_camera_physical"); it != gc.extensions.end())
      read_physical_camera(it->second, label + " EXT_camera_physical", cam.lens);
    read_lens(gc.extras, label + " extras.lens", cam.lens);
    read_lens(node.extras, node_label(n) + " extras.lens", cam.lens);
    scene_.cameras.push_back(cam);
  }

  // The draft EXT_camera_physical extension (Khronos glTF pull request 2608, a proposal, not
  // ratified): focalLength and fStop as given, focusDistance unless 0 (unset), sensorSize checked
  // but not used (the core perspective camera stays the projection's source, as the draft says).
  void read_physical_camera(const tinygltf::Value& ext, const std::string& label,
                            LensExtras& lens) const {
    if (!ext.IsObject()) fail(label, "must be an object");
    auto number = [&](const char* key, bool zero_ok) -> std::optional<double> {
      if (!ext.Has(key)) return std::nullopt;
      const tinygltf::Value& v = ext.Get(key);
      const double d = v.IsNumber() ? v.GetNumberAsDouble() : std::nan("");
      if (!std::isfinite(d) || d < 0.0 || (d == 0.0 && !zero_ok))
        fail(label, std::string(key) + (zero_ok ? " must be a number >= 0" : " must be > 0"));
      return d;
    };
    if (auto v = number("focalLength", false)) lens.focal_length = v;
    if (auto v = number("fStop", false)) lens.fstop = v;
    if (auto v = number("focusDistance", true); v && *v > 0.0) lens.focus_distance = v;
    if (ext.Has("sensorSize")) {
      const auto size = number_pair(ext.Get("sensorSize"));
      if (!size || !(size->first > 0.0) || !(size->second > 0.0))
        fail(label, "sensorSize must be [width, height] in metres, both > 0");
    }
  }

  // Two finite numbers, [a, b]; nullopt for anything else.
  static std::optional<std::pair<double, double>> number_pair(const tinygltf::Value& v) {
    if (!v.IsArray() || v.ArrayLen() != 2) return std::nullopt;
    const auto item = [&](int i) {
      return v.Get(i).IsNumber() ? v.Get(i).GetNumberAsDouble() : std::nan("");
    };
    if (!std::isfinite(item(0)) || !std::isfinite(item(1))) return std::nullopt;
    return std::pair{item(0), item(1)};
  }

  void read_lens(const tinygltf::Value& extras, const std::string& label, LensExtras& lens) const {
    if (!extras.IsObject() || !extras.Has("lens")) return;
    const tinygltf::Value& obj = extras.Get("lens");
    if (!obj.IsObject()) fail(label, "must be an object");
    auto read = [&](const char* key, std::optional<double>& out) {
      if (!obj.Has(key)) return;
      const tinygltf::Value& v = obj.Get(key);
      double d = v.IsNumber() ? v.GetNumberAsDouble() : std::nan("");
      if (!(d > 0.0) || !std::isfinite(d))
        fail(label, std::string(key) + " must be a positive number of " +
                        (std::strcmp(key, "fstop") == 0 ? "f-stops" : "metres"));
      out = d;
    };
    read("focal_length", lens.focal_length);
    read("fstop", lens.fstop);
    read("focus_distance", lens.focus_distance);
    // The aperture's shape (lens/aperture.h), checked as a whole once read.
    auto number = [&](const char* key) -> std::optional<double> {
      if (!obj.Has(key)) return std::nullopt;
      const tinygltf::Value& v = obj.Get(key);
      if (!v.IsNumber() || !std::isfinite(v.GetNumberAsDouble()))
        fail(label, std::string(key) + " must be a number");
      return v.GetNumberAsDouble();
    };
    lens::ApertureChoices& a = lens.aperture;
    if (auto blades = number("aperture_blades")) {
      a.blades = lens::blade_count(*blades);
      if (!a.blades) fail(label, "aperture_blades must be a whole number");
    }
    // Key by key, like the others: the node's values win over the camera object's.
    if (auto v = number("aperture_rotation")) a.rotation_deg = v;
    if (auto v = number("aperture_roundness")) a.roundness = v;
    if (auto v = number("anamorphic_ratio")) a.anamorphic_ratio = v;
    if (obj.Has("aperture_profile")) {
      const tinygltf::Value& v = obj.Get("aperture_profile");
      if (!v.IsString()) fail(label, "aperture_profile must be uniform, centre or rim");
      try {
        a.profile = lens::parse_aperture_profile(v.Get<std::string>());
      } catch (const Error& e) {
        fail(label, e.what());
      }
    }
    if (auto v = number("aperture_profile_strength")) a.profile_strength = v;
    if (auto v = number("axial_ca")) a.axial_ca = v;
    if (auto v = number("lateral_ca")) a.lateral_ca = v;
    if (obj.Has("aperture_image")) {  // a file name, relative to the glTF file's directory
      const tinygltf::Value& v = obj.Get("aperture_image");
      if (!v.IsString() || v.Get<std::string>().empty())
        fail(label, "aperture_image must be a file name");
      std::filesystem::path file(v.Get<std::string>());
      if (file.is_relative()) file = std::filesystem::path(gltf::base_dir_of(name_)) / file;
      a.image = file.string();
    }
    for (auto [key, field] : {std::pair{"lens_tilt", &a.lens_tilt},
                              std::pair{"lens_shift", &a.lens_shift}}) {
      if (!obj.Has(key)) continue;
      *field = number_pair(obj.Get(key));
      if (!*field) fail(label, std::string(key) + " must be [x, y]");
    }
    if (obj.Has("vignetting_stop")) {
      const auto stop = number_pair(obj.Get("vignetting_stop"));
      if (!stop) fail(label, "vignetting_stop must be [radius, distance] in metres");
      a.vignetting_stop = lens::VignettingStop{stop->first, stop->second};
    }
    try {
      a.shape().validate();
    } catch (const Error& e) {
      fail(label, e.what());
    }
  }

  // What glTF viewers do without a camera: look down -Z at the bounds centre from far enough for
  // the bounding sphere to fit the vertical field of view.
  void synthesize_camera() {
    Camera cam;
    cam.name = "auto";
    cam.synthesized = true;
    cam.yfov = 0.8f;
    glm::vec3 center = scene_.bounds.center();
    float radius = std::max(0.5f * scene_.bounds.diagonal(), 1e-3f);
    float distance = radius / std::sin(0.5f * cam.yfov);
    cam.camera_to_world = glm::mat4(1.0f);
    cam.camera_to_world[3] = glm::vec4(center + glm::vec3(0.0f, 0.0f, distance), 1.0f);
    cam.znear = std::max(1e-4f, 0.01f * radius);
    cam.lens.focus_distance = distance;  // focus on the centre
    scene_.cameras.push_back(cam);
  }

  // -- emitters

  void build_emitters() {
    const Mesh& m = scene_.mesh;
    std::vector<double> power;
    for (std::size_t t = 0; t < m.triangles.size(); ++t) {
      const Material& mat = scene_.materials[m.triangle_material[t]];
      if (mat.emissive == glm::vec3(0.0f)) continue;
      glm::vec3 radiance = mat.emissive;
      // Light sampling uses the mean radiance over the triangle, so it must count only what rays
      // can hit: where a MASK cuts the surface out nothing emits, and a BLEND surface is hit (and
      // emits) with probability alpha. Opaque and untextured: the factor itself.
      if (mat.emissive_texture.index >= 0 || mat.alpha_mode != AlphaMode::Opaque) {
        // Mean over the triangle: 10 points of a symmetric barycentric pattern.
        static constexpr float kPattern[10][2] = {
            {1 / 3.f, 1 / 3.f}, {1 / 6.f, 1 / 6.f}, {2 / 3.f, 1 / 6.f}, {1 / 6.f, 2 / 3.f},
            {0.05f, 0.05f},     {0.9f, 0.05f},      {0.05f, 0.9f},      {0.45f, 0.45f},
            {0.05f, 0.45f},     {0.45f, 0.05f}};
        glm::vec3 sum(0.0f);
        for (const auto& b : kPattern) {
          const auto tri = static_cast<std::uint32_t>(t);
          sum += material_emission(tri, b[0], b[1]) * coverage(mat, tri, b[0], b[1]);
        }
        radiance = sum / 10.0f;
      }
      const glm::uvec3& tri = m.triangles[t];
      float area = 0.5f * glm::length(glm::cross(m.positions[tri.y] - m.positions[tri.x],
                                                 m.positions[tri.z] - m.positions[tri.x]));
      float lum = luminance(radiance);
      if (!(lum > 0.0f) || !(area > 0.0f)) continue;
      scene_.emitters.push_back({static_cast<std::uint32_t>(t), area, radiance});
      power.push_back(static_cast<double>(area) * lum);
    }
    scene_.emitter_cdf = cumulative_distribution(power);
  }

  glm::vec3 material_emission(std::uint32_t triangle, float u, float v) const {
    return scene_.material_at(scene_.surface_point(triangle, u, v)).emission;
  }

  // The share of rays that hit the surface at (u, v), as the intersector's alpha test decides.
  float coverage(const Material& mat, std::uint32_t triangle, float u, float v) const {
    if (mat.alpha_mode == AlphaMode::Opaque) return 1.0f;
    const float alpha = scene_.alpha_at(triangle, u, v);
    if (mat.alpha_mode == AlphaMode::Mask) return alpha >= mat.alpha_cutoff ? 1.0f : 0.0f;
    return std::clamp(alpha, 0.0f, 1.0f);
  }

  LoadOptions options_;
  Scene scene_;
  gltf::MaterialReader materials_{model_, name_, scene_.textures, scene_.warnings};
  std::string scene_label_ = "scene";
  int default_material_ = -1;
  bool has_uv_[2] = {false, false};
  bool has_colors_ = false, has_tangents_ = false;
  std::vector<bool> reached_;       // nodes visited so far
  std::vector<int> parent_;         // the parent each was reached from (-1: a root)
  std::uint64_t vertices_ = 0, triangles_ = 0;  // counted against LoadLimits
  std::vector<std::pair<std::uint32_t, glm::vec3>> repaired_;
};

Scene load_model(const std::string& data, const std::string& name, const std::string& base_dir,
                 const LoadOptions& options) {
  gltf::Parsed parsed = gltf::parse(data, name, base_dir, /*load_images=*/true,
                                    options.limits.max_texture_pixels);
  Scene scene = Loader(parsed.model, name, options).load();
  scene.warnings.insert(scene.warnings.begin(), parsed.warnings.begin(), parsed.warnings.end());
  return scene;
}

}  // namespace

Scene load_gltf(const std::string& path, const LoadOptions& options) {
  return load_model(read_file(path), path, gltf::base_dir_of(path), options);
}

Scene load_gltf_from_memory(const std::string& data, const std::string& name,
                            const LoadOptions& options) {
  return load_model(data, name, "", options);
}

}  // namespace dofcache::scene
