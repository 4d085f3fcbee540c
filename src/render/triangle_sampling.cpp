#include "dofcache/render/triangle_sampling.h"

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>

namespace dofcache::render {
namespace {

// The unit part of v orthogonal to the unit vector n.
glm::vec3 orthogonal_part(glm::vec3 v, glm::vec3 n) {
  return glm::normalize(v - glm::dot(v, n) * n);
}

float triangle_area(const Triangle& t) {
  return 0.5f * glm::length(glm::cross(t.b - t.a, t.c - t.a));
}

bool use_solid_angle(float omega) { return omega >= kMinSolidAngle && omega <= kMaxSolidAngle; }

}  // namespace

float solid_angle(glm::vec3 x, const Triangle& t) {
  const glm::vec3 a = t.a - x, b = t.b - x, c = t.c - x;
  const float la = glm::length(a), lb = glm::length(b), lc = glm::length(c);
  if (!(la > 0.0f && lb > 0.0f && lc > 0.0f)) return 0.0f;
  // Unnormalised: tan(Omega/2) = |a.(b x c)| / (la lb lc + (a.b) lc + (b.c) la + (c.a) lb).
  const float numerator = std::abs(glm::dot(a, glm::cross(b, c)));
  const float denominator =
      la * lb * lc + glm::dot(a, b) * lc + glm::dot(b, c) * la + glm::dot(c, a) * lb;
  float omega = 2.0f * std::atan2(numerator, denominator);
  return std::isfinite(omega) ? std::max(omega, 0.0f) : 0.0f;
}

namespace {

// Arvo's warp for the spherical triangle of unit directions A, B, C with area `omega` (its solid
// angle, computed once by the caller). Only the angle alpha at A enters, through its cosine and
// sine: sin(a - alpha) and cos(a - alpha) expand without an inverse trigonometric function, which
// leaves one sincos per sample.
glm::vec3 spherical_warp(glm::vec3 A, glm::vec3 B, glm::vec3 C, float omega, glm::vec2 u) {
  // alpha is the angle between the great-circle planes through A: between A x B and A x C, whose
  // cross product is A (A . (B x C)).
  const glm::vec3 n_ab = glm::cross(A, B), n_ac = glm::cross(A, C);
  const float norms = glm::length(n_ab) * glm::length(n_ac);
  if (!(norms > 0.0f)) return A;
  const float cos_alpha = glm::dot(n_ab, n_ac) / norms;
  const float sin_alpha = std::abs(glm::dot(A, glm::cross(B, C))) / norms;
  // Arvo (1995): choose the sub-triangle A B' C' of area u.x * omega, with C' on the arc AC...
  const float sub_area = u.x * omega;
  const float sin_a = std::sin(sub_area), cos_a = std::cos(sub_area);
  const float s = sin_a * cos_alpha - cos_a * sin_alpha;  // sin(sub_area - alpha)
  const float c = cos_a * cos_alpha + sin_a * sin_alpha;  // cos(sub_area - alpha)
  const float cos_ab = glm::dot(A, B);
  const float p = c - cos_alpha;
  const float q = s + sin_alpha * cos_ab;
  float cos_b = ((q * c - p * s) * cos_alpha - q) / ((q * s + p * c) * sin_alpha);
  cos_b = std::clamp(std::isfinite(cos_b) ? cos_b : 1.0f, -1.0f, 1.0f);
  const glm::vec3 c_prime =
      cos_b * A + std::sqrt(std::max(0.0f, 1.0f - cos_b * cos_b)) * orthogonal_part(C, A);
  // ... then a point on the arc from B to C' whose cosine to B is uniform.
  const float z = 1.0f - u.y * (1.0f - glm::dot(c_prime, B));
  const glm::vec3 w = z * B + std::sqrt(std::max(0.0f, 1.0f - z * z)) * orthogonal_part(c_prime, B);
  return glm::normalize(w);
}

}  // namespace

glm::vec3 sample_spherical_triangle(glm::vec3 x, const Triangle& t, glm::vec2 u) {
  return spherical_warp(glm::normalize(t.a - x), glm::normalize(t.b - x), glm::normalize(t.c - x),
                        solid_angle(x, t), u);
}

bool sample_triangle(glm::vec3 x, const Triangle& t, glm::vec2 u, TriangleSample* s) {
  const glm::vec3 normal = glm::cross(t.b - t.a, t.c - t.a);
  const float twice_area = glm::length(normal);
  if (!(twice_area > 0.0f)) return false;
  const glm::vec3 n = normal / twice_area;
  const float plane_distance = glm::dot(n, t.a - x);  // signed distance of x's plane offset
  const float omega = solid_angle(x, t);
  if (use_solid_angle(omega)) {
    const glm::vec3 wi = spherical_warp(glm::normalize(t.a - x), glm::normalize(t.b - x),
                                        glm::normalize(t.c - x), omega, u);
    const float cos_l = glm::dot(n, wi);
    const float distance = plane_distance / cos_l;
    if (!(distance > 0.0f) || !std::isfinite(distance)) return false;
    s->wi = wi;
    s->distance = distance;
    s->pdf = 1.0f / omega;
    return true;
  }
  // Uniform barycentrics (the square-root warp), then the area density converted to solid angle.
  const float su = std::sqrt(u.x);
  const float b0 = 1.0f - su, b1 = u.y * su;
  const glm::vec3 point = b0 * t.a + b1 * t.b + (1.0f - b0 - b1) * t.c;
  const glm::vec3 d = point - x;
  const float distance2 = glm::dot(d, d);
  if (!(distance2 > 0.0f)) return false;
  const float distance = std::sqrt(distance2);
  const glm::vec3 wi = d / distance;
  const float cos_l = std::abs(glm::dot(n, wi));
  if (!(cos_l > 0.0f)) return false;
  const float pdf = distance2 / (0.5f * twice_area * cos_l);
  if (!std::isfinite(pdf)) return false;
  s->wi = wi;
  s->distance = distance;
  s->pdf = pdf;
  return true;
}

float triangle_pdf(glm::vec3 x, const Triangle& t, glm::vec3 wi, float distance) {
  const float omega = solid_angle(x, t);
  if (use_solid_angle(omega)) return 1.0f / omega;
  const float area = triangle_area(t);
  const glm::vec3 normal = glm::cross(t.b - t.a, t.c - t.a);
  const float cos_l = std::abs(glm::dot(glm::normalize(normal), wi));
  if (!(area > 0.0f && cos_l > 0.0f)) return 0.0f;
  const float pdf = distance * distance / (area * cos_l);
  return std::isfinite(pdf) ? pdf : 0.0f;
}

}  // namespace dofcache::render
