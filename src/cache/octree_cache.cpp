#include "dofcache/cache/octree_cache.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include <glm/common.hpp>
#include <glm/vector_relational.hpp>

#include "dofcache/cache/sample_blocks.h"
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

class OctreeRadianceCache final : public RadianceCache {
 public:
  explicit OctreeRadianceCache(int max_depth) : max_depth_(max_depth) {}

  std::string name() const override { return "octree"; }
  bool lookup(glm::vec3 p, glm::vec3 n, const LookupOptions& options,
              LookupResult* out) const override;
  std::size_t size() const override { return size_; }
  std::size_t memory_bytes() const override {
    return heap_bytes(nodes_) + samples_.memory_bytes();
  }
  void for_each_sample(const std::function<void(const CacheSample&)>& fn) const override;

 protected:
  void add_samples(const std::vector<CacheSample>& samples) override;
  void remove_all() override {
    std::vector<Node>().swap(nodes_);
    BlockSamples().swap(samples_);
    size_ = 0;
  }

 private:
  struct Node {
    std::uint32_t child[8] = {};        // 0: no child (the root, node 0, is nobody's child)
    std::uint32_t begin = 0, end = 0;  // its samples: [begin, end) of samples_
  };
  // Where one sample of a batch is filed.
  struct Filing {
    std::uint32_t node, sample;
    bool operator<(const Filing& o) const {
      return node < o.node || (node == o.node && sample < o.sample);
    }
  };

  void grow_root(glm::dvec3 lo, glm::dvec3 hi);
  void file(std::uint32_t node, glm::dvec3 origin, int exponent, int target, const CacheSample& s,
            std::uint32_t sample, std::vector<Filing>* filings);

  int max_depth_;
  std::vector<Node> nodes_;
  BlockSamples samples_;  // every node's samples, in node order
  std::size_t size_ = 0;  // distinct samples (samples_ holds one copy per node filed in)
  glm::dvec3 root_origin_{0.0};
  int root_exponent_ = 0;  // root edge = 2^root_exponent_
};

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
    nodes_.push_back(nodes_[0]);
    nodes_[0] = Node{};
    nodes_[0].child[oct] = static_cast<std::uint32_t>(nodes_.size() - 1);
    root_origin_ = origin;
    ++root_exponent_;
  }
}

void OctreeRadianceCache::file(std::uint32_t node, glm::dvec3 origin, int exponent, int target,
                               const CacheSample& s, std::uint32_t sample,
                               std::vector<Filing>* filings) {
  if (exponent <= target) {
    filings->push_back({node, sample});
    return;
  }
  glm::dvec3 p(s.position);
  double r = s.radius * kRadiusPad;
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
    file(child, lo, exponent - 1, target, s, sample, filings);
  }
}

void OctreeRadianceCache::add_samples(const std::vector<CacheSample>& samples) {
  std::vector<Filing> filings;
  filings.reserve(2 * samples.size());
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const CacheSample& s = samples[i];
    glm::dvec3 p(s.position);
    double r = s.radius * kRadiusPad;
    grow_root(p - r, p + r);
    // The deepest level whose edge is >= 2r (bounded by max_depth).
    int target = std::max(ceil_log2(2.0 * s.radius), root_exponent_ - max_depth_);
    file(0, root_origin_, root_exponent_, target, s, static_cast<std::uint32_t>(i), &filings);
  }
  // One linear pass, as the vdb backend merges a level: every node's old range, then its new
  // samples, in node order.
  std::sort(filings.begin(), filings.end());
  BlockSamples merged;
  merged.reserve(samples_.size() + filings.size());
  auto next = filings.begin();
  for (std::uint32_t node = 0; node < nodes_.size(); ++node) {
    Node& nd = nodes_[node];
    const auto begin = static_cast<std::uint32_t>(merged.size());
    for (std::uint32_t j = nd.begin; j < nd.end; ++j) merged.append_from(samples_, j);
    for (; next != filings.end() && next->node == node; ++next)
      merged.push_back(samples[next->sample]);
    nd.begin = begin;
    nd.end = static_cast<std::uint32_t>(merged.size());
  }
  samples_.swap(merged);
  size_ += samples.size();
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
      RangeScanner scanner(test, &sum);
      std::uint32_t node = 0;
      for (;;) {
        const Node& nd = nodes_[node];
        if (nd.begin < nd.end) scanner.add(&samples_, nd.begin, nd.end);
        edge *= 0.5;
        glm::dvec3 mid = origin + edge;
        int oct = (q.x >= mid.x ? 1 : 0) | (q.y >= mid.y ? 2 : 0) | (q.z >= mid.z ? 4 : 0);
        node = nd.child[oct];
        if (node == 0) break;
        origin += octant_offset(oct) * edge;
      }
      scanner.flush();
    }
  }
  return sum.finish(options.min_samples, out);
}

void OctreeRadianceCache::for_each_sample(
    const std::function<void(const CacheSample&)>& fn) const {
  // A sample filed in several nodes has a copy in each: visit one per id.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> order(samples_.size());  // (id, index)
  for (std::size_t i = 0; i < samples_.size(); ++i)
    order[i] = {samples_.id(i), static_cast<std::uint32_t>(i)};
  std::sort(order.begin(), order.end());
  for (std::size_t k = 0; k < order.size(); ++k)
    if (k == 0 || order[k].first != order[k - 1].first) fn(samples_.get(order[k].second));
}

}  // namespace

std::unique_ptr<RadianceCache> make_octree_radiance_cache(int max_depth) {
  return std::make_unique<OctreeRadianceCache>(max_depth);
}

}  // namespace dofcache::cache
