#include "dofcache/render/light_sampler.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <limits>
#include <map>

namespace dofcache::render {
namespace {

// 10 bits per axis of p in [0, 1]^3, interleaved: neighbours in space stay near in the order.
std::uint32_t morton3(glm::vec3 p) {
  auto spread = [](float v) {
    auto x = static_cast<std::uint32_t>(std::clamp(v, 0.0f, 1.0f) * 1023.0f);
    x = (x | (x << 16)) & 0x030000FFu;
    x = (x | (x << 8)) & 0x0300F00Fu;
    x = (x | (x << 4)) & 0x030C30C3u;
    x = (x | (x << 2)) & 0x09249249u;
    return x;
  };
  return spread(p.x) | (spread(p.y) << 1) | (spread(p.z) << 2);
}

}  // namespace

LightSampler::LightSampler(const scene::Scene& scene) : scene_(scene) {
  const std::size_t count = scene.emitters.size();
  if (count == 0) return;
  const scene::Mesh& mesh = scene.mesh;
  auto vertex = [&](std::size_t e, int k) {
    return mesh.positions[mesh.triangles[scene.emitters[e].triangle][k]];
  };

  // One group per object (glTF node instance), in order of first appearance.
  std::map<std::uint32_t, std::size_t> group_of_object;
  std::vector<std::vector<std::uint32_t>> groups;
  for (std::size_t e = 0; e < count; ++e) {
    const std::uint32_t t = scene.emitters[e].triangle;
    const std::uint32_t object = t < mesh.triangle_object.size() ? mesh.triangle_object[t] : 0;
    auto [it, inserted] = group_of_object.emplace(object, groups.size());
    if (inserted) groups.emplace_back();
    groups[it->second].push_back(static_cast<std::uint32_t>(e));
  }
  // Too many to weigh per sample: merge neighbours along a Morton order into kMaxLights clusters.
  if (groups.size() > static_cast<std::size_t>(kMaxLights)) {
    const glm::vec3 lo = scene.bounds.lower;
    const glm::vec3 extent = glm::max(scene.bounds.upper - lo, glm::vec3(1e-20f));
    std::vector<std::pair<std::uint32_t, std::size_t>> keyed;
    for (std::size_t g = 0; g < groups.size(); ++g) {
      glm::vec3 c(0.0f);
      for (std::uint32_t e : groups[g]) c += vertex(e, 0);
      keyed.emplace_back(morton3((c / static_cast<float>(groups[g].size()) - lo) / extent), g);
    }
    std::sort(keyed.begin(), keyed.end());
    std::vector<std::vector<std::uint32_t>> merged(kMaxLights);
    for (std::size_t k = 0; k < keyed.size(); ++k) {
      auto& into = merged[k * kMaxLights / keyed.size()];
      const auto& from = groups[keyed[k].second];
      into.insert(into.end(), from.begin(), from.end());
    }
    groups = std::move(merged);
  }

  light_of_.resize(count);
  slot_of_.resize(count);
  for (std::size_t g = 0; g < groups.size(); ++g) {
    Light l;
    l.begin = static_cast<std::uint32_t>(order_.size());
    glm::vec3 lower(std::numeric_limits<float>::max()), upper(-std::numeric_limits<float>::max());
    double total = 0.0;
    std::vector<double> power;
    for (std::uint32_t e : groups[g]) {
      for (int k = 0; k < 3; ++k) {
        lower = glm::min(lower, vertex(e, k));
        upper = glm::max(upper, vertex(e, k));
      }
      const scene::Emitter& em = scene.emitters[e];
      power.push_back(static_cast<double>(em.area) * scene::luminance(em.radiance));
      total += power.back();
      light_of_[e] = static_cast<std::uint32_t>(g);
      slot_of_[e] = static_cast<std::uint32_t>(order_.size());
      order_.push_back(e);
    }
    const std::vector<float> cdf = scene::cumulative_distribution(power);
    cdf_.insert(cdf_.end(), cdf.begin(), cdf.end());
    l.end = static_cast<std::uint32_t>(order_.size());
    l.power = static_cast<float>(total);
    l.center = 0.5f * (lower + upper);
    for (std::uint32_t e : groups[g])
      for (int k = 0; k < 3; ++k)
        l.radius = std::max(l.radius, glm::length(vertex(e, k) - l.center));

    // One-sided and flat: every triangle faces the first one's way, every vertex on its plane.
    const glm::vec3 n0 =
        glm::normalize(glm::cross(vertex(order_[l.begin], 1) - vertex(order_[l.begin], 0),
                                  vertex(order_[l.begin], 2) - vertex(order_[l.begin], 0)));
    const float offset = glm::dot(n0, vertex(order_[l.begin], 0));
    l.one_sided_plane = std::isfinite(n0.x) && std::isfinite(n0.y) && std::isfinite(n0.z);
    for (std::uint32_t e : groups[g]) {
      if (!l.one_sided_plane) break;
      const scene::Emitter& em = scene.emitters[e];
      const glm::vec3 n =
          glm::normalize(glm::cross(vertex(e, 1) - vertex(e, 0), vertex(e, 2) - vertex(e, 0)));
      bool flat = glm::dot(n, n0) > 1.0f - 1e-5f;
      for (int k = 0; k < 3; ++k)
        flat = flat && std::abs(glm::dot(n0, vertex(e, k)) - offset) <= 1e-5f * (l.radius + 1.0f);
      l.one_sided_plane =
          flat && !scene.materials[mesh.triangle_material[em.triangle]].double_sided;
    }
    l.normal = n0;
    l.offset = offset;
    lights_.push_back(l);
  }
}

float LightSampler::weights(glm::vec3 x, glm::vec3 n, float* w) const {
  float sum = 0.0f;
  for (std::size_t i = 0; i < lights_.size(); ++i) {
    const Light& l = lights_[i];
    const glm::vec3 d = l.center - x;
    float wi = 0.0f;
    // Zero only where every point of the light gives zero: wholly below the horizon of n, or the
    // point behind a one-sided flat light (a small tolerance keeps points on its plane).
    const bool below = glm::dot(n, d) < -l.radius;
    const bool behind = l.one_sided_plane && glm::dot(l.normal, x) - l.offset < -1e-6f * l.radius;
    if (!below && !behind) wi = l.power / std::max(glm::dot(d, d), l.radius * l.radius);
    w[i] = wi;
    sum += wi;
  }
  return sum;
}

bool LightSampler::sample(glm::vec3 x, glm::vec3 n, float u, std::size_t* emitter,
                          float* probability) const {
  if (lights_.empty()) return false;
  if (lights_.size() == 1) {  // exactly power sampling
    *emitter = scene_.sample_emitter(u, probability);
    return true;
  }
  float w[kMaxLights];
  const float sum = weights(x, n, w);
  if (!(sum > 0.0f) || !std::isfinite(sum)) return false;
  // Choose the light, then reuse u's remainder within it for the triangle.
  float t = u * sum;
  std::size_t li = 0;
  for (; li + 1 < lights_.size() && (w[li] == 0.0f || t >= w[li]); ++li) t -= w[li];
  while (w[li] == 0.0f) --li;  // rounding ran past the last light with weight
  const Light& l = lights_[li];
  const float v = std::clamp(t / w[li], 0.0f, 0x1.fffffep-1f);
  const float* first = cdf_.data() + l.begin;
  const float* last = cdf_.data() + l.end;
  const float* it = std::min(std::upper_bound(first, last, v), last - 1);
  const float pick = *it - (it > first ? it[-1] : 0.0f);
  *emitter = order_[static_cast<std::size_t>(it - cdf_.data())];
  *probability = w[li] / sum * pick;
  return true;
}

float LightSampler::probability(glm::vec3 x, glm::vec3 n, std::size_t emitter) const {
  if (emitter >= light_of_.size()) return 0.0f;
  const std::uint32_t slot = slot_of_[emitter];
  const Light& l = lights_[light_of_[emitter]];
  if (lights_.size() == 1)  // as Scene::sample_emitter reports it
    return scene_.emitter_cdf[emitter] - (emitter > 0 ? scene_.emitter_cdf[emitter - 1] : 0.0f);
  const float pick = cdf_[slot] - (slot > l.begin ? cdf_[slot - 1] : 0.0f);
  float w[kMaxLights];
  const float sum = weights(x, n, w);
  if (!(sum > 0.0f) || !std::isfinite(sum)) return 0.0f;
  return w[light_of_[emitter]] / sum * pick;
}

float LightSampler::nearest_light_distance(glm::vec3 x) const {
  float nearest = std::numeric_limits<float>::infinity();
  for (const Light& l : lights_)
    nearest = std::min(nearest, std::max(0.0f, glm::length(x - l.center) - l.radius));
  return nearest;
}

}  // namespace dofcache::render
