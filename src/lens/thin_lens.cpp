#include "dofcache/lens/thin_lens.h"

#include <cmath>
#include <limits>
#include <string>

#include <glm/geometric.hpp>

#include "dofcache/core/error.h"

namespace dofcache::lens {

double focal_length_from_distances(double object_distance, double image_distance) {
  return 1.0 / (1.0 / object_distance + 1.0 / image_distance);  // eq. (2.1)
}

double image_distance(double focal_length, double depth) {
  return focal_length * depth / (depth - focal_length);  // eqs. (2.2), (2.3)
}

double coc_diameter(double focal_length, double fstop, double focus_distance, double depth) {
  double v_p = image_distance(focal_length, focus_distance);
  double v_d = image_distance(focal_length, depth);
  return std::abs(v_d - v_p) * focal_length / (fstop * v_d);  // eq. (2.4)
}

double cone_radius(double focal_length, double fstop, double focus_distance, double depth) {
  return 0.5 * (focal_length / fstop) * std::abs(depth - focus_distance) / focus_distance;  // (2.5)
}

double projected_cone_radius(double focal_length, double fstop, double focus_distance,
                             double depth) {
  double v_p = image_distance(focal_length, focus_distance);
  return cone_radius(focal_length, fstop, focus_distance, depth) * v_p / depth;  // eq. (2.6)
}

double ThinLens::coc_diameter(double depth) const {
  return lens::coc_diameter(focal_length, fstop, focus_distance, depth);
}

double ThinLens::cone_radius(double depth) const {
  return lens::cone_radius(focal_length, fstop, focus_distance, depth);
}

void ThinLens::stop_circles(glm::dvec2 slopes, double depth, StopCircle out[2]) const {
  out[0] = out[1] = StopCircle{};
  const double r = aperture_radius();
  // A stop of radius R at distance d in front of the lens: the ray from the aperture point l to
  // the point (slopes s, depth D) crosses its plane at l (1 - d / D) + s d, so it passes where
  // |l + s d / k| <= R / k, k = (1 - d / D) r in aperture units.
  auto front = [&](const VignettingStop& stop) {
    if (!(stop.radius > 0.0 && depth > stop.distance)) return;
    const double k = (1.0 - stop.distance / depth) * r;
    out[0] = {-slopes * (stop.distance / k), stop.radius / k};
  };
  front(aperture.stop);
  front(aperture.rims.front);
  const VignettingStop& rear = aperture.rims.rear;
  if (rear.radius > 0.0) {
    // Behind the lens at d, between it and the point's image at V_D (s V_D from the axis,
    // turned over): the ray from l crosses the stop's plane at l (1 - d / V_D) - s d.
    const double v = depth > focal_length ? image_distance(focal_length, depth) : 1e30;
    const double k = (1.0 - rear.distance / v) * r;
    if (k > 0.0) out[1] = {slopes * (rear.distance / k), rear.radius / k};
  }
}

void ThinLens::validate() const {
  auto check = [](double v, const char* name) {
    if (!std::isfinite(v) || v <= 0.0)
      throw Error(std::string("lens: ") + name + " must be a positive number, got " +
                  std::to_string(v));
  };
  check(focal_length, "focal length");
  check(fstop, "f-number");
  check(focus_distance, "focus distance");
  if (focal_length > 10.0) throw Error("lens: focal length is in metres; " +
                                       std::to_string(focal_length) + " m is absurd");
  if (focus_distance <= focal_length)
    throw Error("lens: focus distance (" + std::to_string(focus_distance) +
                " m) must exceed the focal length (" + std::to_string(focal_length) + " m)");
  aperture.validate();
  // Every colour band's plane of focus lies beyond the focal length too.
  if (focus_distance - 0.5 * std::abs(aperture.axial_ca) <= focal_length)
    throw Error("lens: axial chromatic aberration of " + std::to_string(aperture.axial_ca) +
                " m puts the blue plane of focus at or before the focal length");
}

double film_height(double film_distance, double yfov) {
  return 2.0 * film_distance * std::tan(0.5 * yfov);
}

double LensImaging::pixel_pitch() const {
  return film_height(lens.film_distance(), yfov) / y_resolution;
}

double LensImaging::pixel_footprint(double depth) const {
  return pixel_pitch() * depth / lens.film_distance();  // eq. (4.1)
}

double LensImaging::signed_coc_pixels(double depth) const {
  double c = lens.coc_diameter(depth) / pixel_pitch();
  return depth < lens.focus_distance ? -c : c;
}

double LensImaging::coc_radius_pixels(double depth) const {
  return 0.5 * lens.coc_diameter(depth) / pixel_pitch();
}

double LensImaging::depth_for_signed_coc(double coc_pixels) const {
  // C(D) = A V_P |D - P| / (D P) (eq. (2.4) rewritten, A the aperture diameter). Signed, in
  // pixels: c = k (D - P) / D with k = A V_P / (P pitch), so D = k P / (k - c); c -> k is infinity.
  double k = lens.aperture_diameter() * lens.film_distance() / (lens.focus_distance * pixel_pitch());
  if (coc_pixels >= k) return std::numeric_limits<double>::infinity();
  return k * lens.focus_distance / (k - coc_pixels);
}

glm::vec2 concentric_disk(glm::vec2 u) {
  glm::vec2 o = 2.0f * u - 1.0f;
  if (o.x == 0.0f && o.y == 0.0f) return {0.0f, 0.0f};
  constexpr float kPiOver4 = 0.78539816339f;
  float r, theta;
  if (std::abs(o.x) > std::abs(o.y)) {
    r = o.x;
    theta = kPiOver4 * (o.y / o.x);
  } else {
    r = o.y;
    theta = 2.0f * kPiOver4 - kPiOver4 * (o.x / o.y);
  }
  return r * glm::vec2(std::cos(theta), std::sin(theta));
}

DiskPolar concentric_polar(glm::vec2 u) {
  const glm::vec2 o = 2.0f * u - 1.0f;
  if (o.x == 0.0f && o.y == 0.0f) return {0.0f, 0.0f};
  // concentric_disk's angle over 2 pi; a negative r there is the opposite direction, half a turn.
  float radius, turn;
  if (std::abs(o.x) > std::abs(o.y)) {
    radius = std::abs(o.x);
    turn = 0.125f * (o.y / o.x) + (o.x < 0.0f ? 0.5f : 0.0f);
  } else {
    radius = std::abs(o.y);
    turn = 0.25f - 0.125f * (o.x / o.y) + (o.y < 0.0f ? 0.5f : 0.0f);
  }
  if (turn < 0.0f) turn += 1.0f;
  return {radius, std::min(turn, 0x1.fffffep-1f)};
}

}  // namespace dofcache::lens

namespace dofcache::lens {

TiltedFocus focus_plane_through(const glm::dvec3 (&points)[3], double focal_length) {
  for (const glm::dvec3& p : points)
    if (!(p.z > 0.0) || !std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      throw Error("plane of focus: every point must be a surface ahead of the lens");
  // Rows (z, -y, -x) . (u, v, w) = 1, u = 1 / P, v = sin(tilt_x) / F, w = sin(tilt_y) / F:
  // Cramer's rule.
  auto det = [](const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
    return glm::dot(a, glm::cross(b, c));
  };
  const glm::dvec3 r0(points[0].z, -points[0].y, -points[0].x);
  const glm::dvec3 r1(points[1].z, -points[1].y, -points[1].x);
  const glm::dvec3 r2(points[2].z, -points[2].y, -points[2].x);
  // The columns of the system's matrix are the rows' components.
  const glm::dvec3 c0(r0.x, r1.x, r2.x), c1(r0.y, r1.y, r2.y), c2(r0.z, r1.z, r2.z);
  const glm::dvec3 one(1.0);
  const double d = det(c0, c1, c2);
  // Relative to the size of the points' triangle seen from the lens (collinear, or a plane
  // through the lens's centre: no single plane of focus).
  const double scale = glm::length(r0) * glm::length(r1) * glm::length(r2);
  if (!(std::abs(d) > 1e-9 * scale))
    throw Error("plane of focus: the three points lie on one line or on a plane through the "
                "lens; pick points that span a plane");
  const double u = det(one, c1, c2) / d, v = det(c0, one, c2) / d, w = det(c0, c1, one) / d;
  if (!(u > 0.0) || 1.0 / u <= focal_length)
    throw Error("plane of focus: the plane through the points meets the optical axis " +
                std::string(u > 0.0 ? "within the focal length" : "behind the lens"));
  const double sx = v * focal_length, sy = w * focal_length;
  if (!(std::abs(sx) < 1.0 && std::abs(sy) < 1.0))
    throw Error("plane of focus: the plane through the points needs a tilt of 90 degrees or more");
  constexpr double kDegrees = 180.0 / M_PI;
  return {1.0 / u, std::asin(sx) * kDegrees, std::asin(sy) * kDegrees};
}

}  // namespace dofcache::lens
