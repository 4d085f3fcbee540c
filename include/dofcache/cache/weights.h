#pragma once
// Interpolation weights of the radiance cache (paper section 4.2, eqs. (4.3) and (4.4)), the
// acceptance test every lookup applies, and the canonical-order weighted sum.
//
// Every lookup path (octree, vdb, the per-tile buffer, the brute-force reference of the tests)
// calls SampleTest::weight and WeightedSum, so given the same samples they accept the same set and
// return bit-identical values: the sum runs in increasing sample id, whatever order a data
// structure happens to visit the samples in.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "dofcache/cache/sample.h"

namespace dofcache::cache {

// Eq. (4.3): eps_i = ||p - p_i|| / (r_i (n . n_i)), r_i the sample's radius (d_max,i).
inline float sample_error(glm::vec3 p, glm::vec3 n, glm::vec3 p_i, glm::vec3 n_i, float r_i) {
  glm::vec3 d = p - p_i;
  return std::sqrt(glm::dot(d, d)) / (r_i * glm::dot(n, n_i));
}

// Eq. (4.4): w_i = (1 - eps_i)^2, for eps_i < 1.
inline float sample_weight(float error) {
  float t = 1.0f - error;
  return t * t;
}

// cos(max_normal_angle_deg), clamped to stay positive so that eq. (4.3) never divides by a
// non-positive n . n_i. Memoised per thread: lookups call it with the same angle every time.
inline float min_normal_dot(float max_normal_angle_deg) {
  thread_local float last_angle = -1.0f;
  thread_local float last_dot = 1.0f;
  if (max_normal_angle_deg != last_angle) {
    constexpr float kDegToRad = 3.14159265358979f / 180.0f;
    last_dot = std::max(std::cos(max_normal_angle_deg * kDegToRad), 1e-4f);
    last_angle = max_normal_angle_deg;
  }
  return last_dot;
}

// The acceptance test of one query point against samples.
class SampleTest {
 public:
  SampleTest(glm::vec3 p, glm::vec3 n, const LookupOptions& options)
      : p_(p),
        n_(n),
        min_dot_(min_normal_dot(options.max_normal_angle_deg)),
        front_limit_(options.reject_in_front ? -2.0f * options.front_tolerance : -INFINITY),
        anisotropic_(options.anisotropic()),
        squeeze_(options.footprint_squeeze),
        axis_(options.footprint_axis),
        floor_(options.floor_per_depth *
               std::max(0.0f, glm::dot(p - options.camera_position, options.camera_forward))) {}

  glm::vec3 position() const { return p_; }

  // w_i > 0 if the sample is accepted, 0 if rejected. Accepted means, in this order (cheapest
  // and most selective first): ||p - p_i|| < r_i; n . n_i >= cos(max angle); not in front of the
  // query point; eps_i < 1 (eq. (4.3)). The first test is implied by the last in exact arithmetic;
  // stating it keeps the spatial structures' conservative bounds valid under rounding. An
  // anisotropic footprint (LookupOptions) lengthens the offset in eq. (4.3) along the squeezed
  // axes, so what it accepts lies inside the sphere the structures search.
  float weight(glm::vec3 p_i, float r_i, glm::vec3 n_i) const {
    glm::vec3 d = p_ - p_i;
    float d2 = glm::dot(d, d);
    if (!(d2 < r_i * r_i)) return 0.0f;
    float c = glm::dot(n_, n_i);
    if (!(c >= min_dot_)) return 0.0f;
    // (p - p_i) . (n + n_i) / 2 < -tolerance * r_i, both sides doubled.
    if (glm::dot(d, n_ + n_i) < front_limit_ * r_i) return 0.0f;
    if (anisotropic_) {  // the offset along the squeezed axis counts r_i / reach times
      const float reach = std::max(squeeze_ * r_i, floor_);
      if (reach < r_i) {
        const float a = glm::dot(d, axis_);
        d2 += a * a * ((r_i * r_i) / (reach * reach) - 1.0f);
      }
    }
    float eps = std::sqrt(d2) / (r_i * c);  // eq. (4.3)
    if (!(eps < 1.0f)) return 0.0f;
    return sample_weight(eps);  // eq. (4.4)
  }

 private:
  glm::vec3 p_, n_;
  float min_dot_;
  float front_limit_;
  bool anisotropic_;
  float squeeze_;
  glm::vec3 axis_;
  float floor_;  // the in-focus reach at the query's depth
};

// Collects accepted samples and sums them in increasing id: result = sum w_i v_i / sum w_i.
class WeightedSum {
 public:
  void add(std::uint32_t id, float w, glm::vec3 value) {
    if (count_ < kInline) {
      inline_[count_] = {id, w, value};
    } else {
      if (count_ == kInline) overflow_.assign(inline_.begin(), inline_.end());
      overflow_.push_back({id, w, value});
    }
    ++count_;
  }

  int count() const { return static_cast<int>(count_); }

  // Fills *out and returns whether at least min_samples samples were accepted.
  bool finish(int min_samples, LookupResult* out) {
    Entry* e = count_ <= kInline ? inline_.data() : overflow_.data();
    auto by_id = [](const Entry& a, const Entry& b) { return a.id < b.id; };
    if (count_ <= 16) {
      for (std::size_t i = 1; i < count_; ++i)  // insertion sort: usually a handful of entries
        for (std::size_t j = i; j > 0 && by_id(e[j], e[j - 1]); --j) std::swap(e[j], e[j - 1]);
    } else {
      std::sort(e, e + count_, by_id);
    }
    double w_sum = 0.0, r = 0.0, g = 0.0, b = 0.0;
    for (std::size_t i = 0; i < count_; ++i) {
      w_sum += e[i].w;
      r += static_cast<double>(e[i].w) * e[i].value.x;
      g += static_cast<double>(e[i].w) * e[i].value.y;
      b += static_cast<double>(e[i].w) * e[i].value.z;
    }
    if (out) {
      out->count = static_cast<int>(count_);
      out->weight_sum = static_cast<float>(w_sum);
      out->value = glm::vec3(0.0f);
      if (w_sum > 0.0) {
        double inv = 1.0 / w_sum;
        out->value = glm::vec3(static_cast<float>(r * inv), static_cast<float>(g * inv),
                               static_cast<float>(b * inv));
      }
      if (out->accepted_ids)
        for (std::size_t i = 0; i < count_; ++i) out->accepted_ids->push_back(e[i].id);
    }
    return static_cast<int>(count_) >= std::max(min_samples, 1);
  }

 private:
  struct Entry {
    std::uint32_t id;
    float w;
    glm::vec3 value;
  };
  static constexpr std::size_t kInline = 32;
  std::array<Entry, kInline> inline_;
  std::vector<Entry> overflow_;
  std::size_t count_ = 0;
};

}  // namespace dofcache::cache
