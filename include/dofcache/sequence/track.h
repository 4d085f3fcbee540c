#pragma once
// Keyframe tracks with the interpolation modes of glTF 2.0 animation samplers (spec, Appendix C
// "Interpolation"): STEP, LINEAR (spherical for rotations) and CUBICSPLINE (cubic Hermite with
// explicit tangents). One track animates one quantity: a scalar (lens values), a vector
// (translation, scale, look-at target) or a rotation.
#include <string>
#include <vector>

#include <glm/gtc/quaternion.hpp>
#include <glm/vec3.hpp>

namespace dofcache::sequence {

enum class Interpolation { Step, Linear, CubicSpline };

// "STEP", "LINEAR" or "CUBICSPLINE" (the glTF names; case-insensitive). Throws dofcache::Error
// naming `label` for anything else.
Interpolation parse_interpolation(const std::string& name, const std::string& label);
const char* interpolation_name(Interpolation mode);

template <class T>
struct Track {
  Interpolation interpolation = Interpolation::Linear;
  std::vector<double> times;  // key times in seconds, strictly increasing
  // STEP and LINEAR: one value per key. CUBICSPLINE: three per key, as glTF stores them:
  // in-tangent a_k, value v_k, out-tangent b_k (tangents in units per second).
  std::vector<T> values;

  bool empty() const { return times.empty(); }
  std::size_t key_count() const { return times.size(); }
  // The value of key k (the middle element of a CUBICSPLINE triple).
  const T& key_value(std::size_t k) const {
    return values[interpolation == Interpolation::CubicSpline ? 3 * k + 1 : k];
  }

  // The animated value at time t; before the first key the first value, after the last key the
  // last value. Rotations are unit quaternions: LINEAR takes the shortest arc (slerp), CUBICSPLINE
  // normalises the Hermite result, as the glTF specification prescribes.
  T at(double t) const;

  // Throws dofcache::Error naming `label` unless there is at least one key, the times are finite
  // and strictly increasing, the value count matches the mode and every value is finite.
  void validate(const std::string& label) const;
};

extern template struct Track<double>;
extern template struct Track<glm::dvec3>;
extern template struct Track<glm::dquat>;

}  // namespace dofcache::sequence
