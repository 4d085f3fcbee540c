#include "dofcache/sequence/track.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <type_traits>

#include "dofcache/core/error.h"

namespace dofcache::sequence {
namespace {

bool finite(double v) { return std::isfinite(v); }
bool finite(const glm::dvec3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}
bool finite(const glm::dquat& q) {
  return std::isfinite(q.x) && std::isfinite(q.y) && std::isfinite(q.z) && std::isfinite(q.w);
}

glm::dquat normalized(const glm::dquat& q) {
  double len = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
  return len > 0.0 ? q * (1.0 / len) : glm::dquat(1.0, 0.0, 0.0, 0.0);
}

// Spherical linear interpolation along the shorter arc (glTF 2.0, Appendix C).
glm::dquat slerp(const glm::dquat& a, glm::dquat b, double s) {
  double d = a.x * b.x + a.y * b.y + a.z * b.z + a.w * b.w;
  if (d < 0.0) {
    b = -b;
    d = -d;
  }
  if (d > 1.0 - 1e-9) return normalized(a * (1.0 - s) + b * s);  // nearly equal: lerp suffices
  double angle = std::acos(std::min(d, 1.0));
  double sin_angle = std::sin(angle);
  return a * (std::sin((1.0 - s) * angle) / sin_angle) + b * (std::sin(s * angle) / sin_angle);
}

template <class T>
T interpolate_linear(const T& a, const T& b, double s) {
  if constexpr (std::is_same_v<T, glm::dquat>)
    return slerp(a, b, s);
  else
    return a * (1.0 - s) + b * s;
}

}  // namespace

Interpolation parse_interpolation(const std::string& name, const std::string& label) {
  std::string upper = name;
  for (char& c : upper) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  if (upper == "STEP") return Interpolation::Step;
  if (upper == "LINEAR") return Interpolation::Linear;
  if (upper == "CUBICSPLINE") return Interpolation::CubicSpline;
  throw Error(label + ": unknown interpolation '" + name + "' (valid: STEP, LINEAR, CUBICSPLINE)");
}

const char* interpolation_name(Interpolation mode) {
  switch (mode) {
    case Interpolation::Step: return "STEP";
    case Interpolation::Linear: return "LINEAR";
    case Interpolation::CubicSpline: return "CUBICSPLINE";
  }
  return "?";
}

template <class T>
T Track<T>::at(double t) const {
  const std::size_t n = times.size();
  if (t <= times.front() || n == 1) return key_value(0);
  if (t >= times.back()) return key_value(n - 1);
  // Key k with times[k] <= t < times[k + 1].
  std::size_t k = static_cast<std::size_t>(std::upper_bound(times.begin(), times.end(), t) -
                                           times.begin()) - 1;
  const double td = times[k + 1] - times[k];
  const double s = (t - times[k]) / td;
  switch (interpolation) {
    case Interpolation::Step:
      return values[k];
    case Interpolation::Linear:
      return interpolate_linear(values[k], values[k + 1], s);
    case Interpolation::CubicSpline: {
      // p(s) = (2s^3 - 3s^2 + 1) v_k + td (s^3 - 2s^2 + s) b_k + (-2s^3 + 3s^2) v_k+1
      //        + td (s^3 - s^2) a_k+1
      const double s2 = s * s, s3 = s2 * s;
      const T& v0 = values[3 * k + 1];
      const T& b0 = values[3 * k + 2];
      const T& a1 = values[3 * k + 3];
      const T& v1 = values[3 * k + 4];
      T p = v0 * (2 * s3 - 3 * s2 + 1) + b0 * (td * (s3 - 2 * s2 + s)) + v1 * (-2 * s3 + 3 * s2) +
            a1 * (td * (s3 - s2));
      if constexpr (std::is_same_v<T, glm::dquat>) p = normalized(p);
      return p;
    }
  }
  return key_value(0);
}

template <class T>
void Track<T>::validate(const std::string& label) const {
  if (times.empty()) throw Error(label + ": no keyframes");
  for (std::size_t k = 0; k < times.size(); ++k) {
    if (!std::isfinite(times[k])) throw Error(label + ": key time is not finite");
    if (k > 0 && !(times[k] > times[k - 1]))
      throw Error(label + ": key times must be strictly increasing (key " + std::to_string(k) +
                  " at " + std::to_string(times[k]) + " s)");
  }
  std::size_t expected = times.size() * (interpolation == Interpolation::CubicSpline ? 3 : 1);
  if (values.size() != expected)
    throw Error(label + ": " + std::to_string(values.size()) + " values for " +
                std::to_string(times.size()) + " keys (" + interpolation_name(interpolation) +
                " needs " + std::to_string(expected) + ")");
  for (const T& v : values)
    if (!finite(v)) throw Error(label + ": a keyframe value is not finite");
  if constexpr (std::is_same_v<T, glm::dquat>) {
    for (std::size_t k = 0; k < times.size(); ++k) {
      const glm::dquat& q = key_value(k);
      double len = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
      if (!(std::abs(len - 1.0) < 1e-2))
        throw Error(label + ": rotation of key " + std::to_string(k) + " is not a unit quaternion");
    }
  }
}

template struct Track<double>;
template struct Track<glm::dvec3>;
template struct Track<glm::dquat>;

}  // namespace dofcache::sequence
