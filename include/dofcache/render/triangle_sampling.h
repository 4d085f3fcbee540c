#pragma once
// Sampling a triangle light as seen from a shading point.
//
// By area, a point picked uniformly on the triangle has solid-angle density d^2 / (A |cos_l|),
// which grows without bound as the shading point nears the light: a wall a centimetre from a
// lamp's edge sees 1/d^2 spikes that no sample count averages away. By solid angle (Arvo 1995,
// "Stratified sampling of spherical triangles"), the density is 1 / Omega, constant over the
// triangle, so a diffuse receiver's estimate L_e cos Omega / pi is bounded by L_e Omega / pi.
// Solid-angle sampling costs a few trigonometric functions and loses precision for triangles that
// subtend almost nothing or almost a hemisphere, so, as pbrt-v4 does, it is used only in between
// (kMinSolidAngle .. kMaxSolidAngle) and area sampling elsewhere; there area sampling is bounded
// (far away) or the point practically touches the light.
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

namespace dofcache::render {

constexpr float kMinSolidAngle = 3e-4f;  // sr: below, area sampling
constexpr float kMaxSolidAngle = 6.22f;  // sr: above (nearly a hemisphere), area sampling

struct Triangle {
  glm::vec3 a, b, c;
};

// Solid angle subtended by the triangle at x (Van Oosterom & Strackee 1983):
// tan(Omega / 2) = |A . (B x C)| / (1 + A.B + B.C + C.A) for the unit directions A, B, C.
float solid_angle(glm::vec3 x, const Triangle& t);

// A direction from x towards the triangle, the distance to the triangle along it and the
// solid-angle density with which it was chosen.
struct TriangleSample {
  glm::vec3 wi{0.0f};
  float distance = 0.0f;
  float pdf = 0.0f;
};

// Samples the triangle from x with u in [0, 1)^2: by solid angle where that is well conditioned,
// else by area. False if x lies in the triangle's plane or the triangle is degenerate.
bool sample_triangle(glm::vec3 x, const Triangle& t, glm::vec2 u, TriangleSample* s);

// The density with which sample_triangle(x, t, .) returns direction wi that meets the triangle at
// `distance` (for multiple importance sampling); 0 where it never would.
float triangle_pdf(glm::vec3 x, const Triangle& t, glm::vec3 wi, float distance);

// Arvo's warp alone: a unit direction from x, uniform over the triangle's solid angle.
glm::vec3 sample_spherical_triangle(glm::vec3 x, const Triangle& t, glm::vec2 u);

}  // namespace dofcache::render
