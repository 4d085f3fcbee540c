#include "dofcache/cache/octree_cache.h"

#include <algorithm>
#include <cassert>
#include <utility>

#include <glm/common.hpp>
#include <glm/vector_relational.hpp>

#include "grid_math.h"

namespace dofcache::cache {
namespace {

glm::dvec3 octant_offset(int oct) {
  return glm::dvec3(oct & 1, (oct >> 1) & 1, (oct >> 2) & 1);
}

// Squared distance from p to the closed box [lo, lo + edge].
double box_distance2(glm::dvec3 p, glm::dvec3 lo, double edge) {
  double d2 = 0.0;
  for (int a = 0; a < 3; ++a) {
    double c = std::clamp(p[a], lo[a], lo[a] + edge);
    d2 += (c - p[a]) * (c - p[a]);
  }
  return d2;
}

}  // namespace

OctreeRadianceCache::OctreeRadianceCache(int max_depth) : max_depth_(max_depth) {}

void OctreeRadianceCache::grow_root(glm::dvec3 lo, glm::dvec3 hi) {
  if (nodes_.empty()) {
    // First sample: the smallest power-of-two cube with its corner at the sphere's lower corner.
    root_origin_ = lo;
    root_exponent_ = ceil_log2(std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z}));
    nodes_.emplace_back();
    return;
  }
  // Re-root: double the root towards [lo, hi] until it contains it; the old root becomes the
  // child in the octant away from the growth.
  for (;;) {
    double edge = std::ldexp(1.0, root_exponent_);
    if (glm::all(glm::greaterThanEqual(lo, root_origin_)) &&
        glm::all(glm::lessThanEqual(hi, root_origin_ + edge)))
      return;
    glm::dvec3 origin = root_origin_;
    int oct = 0;
    for (int a = 0; a < 3; ++a)
      if (lo[a] < root_origin_[a]) {
        origin[a] -= edge;
        oct |= 1 << a;
      }
    Node old_root = std::move(nodes_[0]);
    nodes_[0] = Node{};
    nodes_.push_back(std::move(old_root));
    nodes_[0].child[oct] = static_cast<std::uint32_t>(nodes_.size() - 1);
    root_origin_ = origin;
    ++root_exponent_;
  }
}

void OctreeRadianceCache::add_to(std::uint32_t node, glm::dvec3 origin, int exponent, int target,
                                 std::uint32_t slot) {
  if (exponent <= target) {
    nodes_[node].samples.push_back(slot);
    return;
  }
  const glm::vec4& s = store_.sphere(slot);
  glm::dvec3 p(s.x, s.y, s.z);
  double r = s.w * kRadiusPad;
  double half = std::ldexp(1.0, exponent - 1);
  for (int oct = 0; oct < 8; ++oct) {
    glm::dvec3 lo = origin + octant_offset(oct) * half;
    if (box_distance2(p, lo, half) > r * r) continue;
    std::uint32_t child = nodes_[node].child[oct];
    if (child == 0) {
      child = static_cast<std::uint32_t>(nodes_.size());
      nodes_.emplace_back();  // may reallocate: index, do not hold references
      nodes_[node].child[oct] = child;
    }
    add_to(child, lo, exponent - 1, target, slot);
  }
}

void OctreeRadianceCache::add_samples(const std::vector<CacheSample>& samples) {
  for (const CacheSample& s : samples) {
    auto slot = static_cast<std::uint32_t>(store_.size());
    store_.push_back(s);
    glm::dvec3 p(s.position);
    double r = s.radius * kRadiusPad;
    grow_root(p - r, p + r);
    // The deepest level whose edge is >= 2r (bounded by max_depth).
    int target = std::max(ceil_log2(2.0 * s.radius), root_exponent_ - max_depth_);
    add_to(0, root_origin_, root_exponent_, target, slot);
  }
}

bool OctreeRadianceCache::lookup(glm::vec3 p, glm::vec3 n, const LookupOptions& options,
                                 LookupResult* out) const {
  WeightedSum sum;
  if (!nodes_.empty()) {
    glm::dvec3 q(p);
    glm::dvec3 origin = root_origin_;
    double edge = std::ldexp(1.0, root_exponent_);
    // The root contains every sample's sphere: outside it nothing can be accepted.
    if (glm::all(glm::greaterThanEqual(q, origin)) &&
        glm::all(glm::lessThanEqual(q, origin + edge))) {
      SampleTest test(p, n, options);
      std::uint32_t node = 0;
      for (;;) {
        const Node& nd = nodes_[node];
        for (std::uint32_t slot : nd.samples) store_.test(slot, test, &sum);
        edge *= 0.5;
        glm::dvec3 mid = origin + edge;
        int oct = (q.x >= mid.x ? 1 : 0) | (q.y >= mid.y ? 2 : 0) | (q.z >= mid.z ? 4 : 0);
        node = nd.child[oct];
        if (node == 0) break;
        origin += octant_offset(oct) * edge;
      }
    }
  }
  return sum.finish(options.min_samples, out);
}

std::size_t OctreeRadianceCache::memory_bytes() const {
  std::size_t bytes = heap_bytes(nodes_) + store_.memory_bytes();
  for (const Node& nd : nodes_) bytes += heap_bytes(nd.samples);
  return bytes;
}

void OctreeRadianceCache::for_each_sample(
    const std::function<void(const CacheSample&)>& fn) const {
  std::vector<std::pair<std::uint32_t, std::uint32_t>> order(store_.size());  // (id, slot)
  for (std::size_t i = 0; i < store_.size(); ++i)
    order[i] = {store_.id(i), static_cast<std::uint32_t>(i)};
  std::sort(order.begin(), order.end());
  for (const auto& [id, slot] : order) fn(store_.get(slot));
}

int OctreeRadianceCache::depth() const {
  int deepest = -1;
  std::vector<std::pair<std::uint32_t, int>> stack;
  if (!nodes_.empty()) stack.push_back({0, 0});
  while (!stack.empty()) {
    auto [node, d] = stack.back();
    stack.pop_back();
    deepest = std::max(deepest, d);
    for (std::uint32_t c : nodes_[node].child)
      if (c) stack.push_back({c, d + 1});
  }
  return deepest;
}

void OctreeRadianceCache::remove_all() {
  std::vector<Node>().swap(nodes_);
  store_.release();
}

}  // namespace dofcache::cache
