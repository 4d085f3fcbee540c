#pragma once
// The GGX (Trowbridge-Reitz) microfacet distribution of the glTF metallic-roughness specular lobe,
// with the separable Smith masking term, and sampling of the normals visible from the viewer
// (Heitz 2018, "Sampling the GGX distribution of visible normals"). In a frame whose z is the
// shading normal, alpha = roughness^2.
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

namespace dofcache::render {

// D(h) for cos(theta_h) = n_h.
float ggx_d(float n_h, float alpha);
// Smith's G1 for a direction at cos(theta) = n_x to the normal.
float smith_g1(float n_x, float alpha);

// A microfacet normal (unit, local frame) drawn from the normals visible from `v` (unit, local
// frame, v.z > 0) in proportion to D(h) max(0, v.h) G1(v.z) / v.z, for u in [0, 1)^2. The
// reflected direction 2 (v.h) h - v then has the density ggx_vndf_pdf, and a lobe's f cos / pdf
// is F G1(n.l): never above 1, where sampling h by D (n.h) alone gives weights that grow without
// bound at grazing views.
glm::vec3 sample_ggx_visible_normal(glm::vec3 v, float alpha, glm::vec2 u);
// The solid-angle density of that reflected direction: D(h) G1(n.v) / (4 n.v), h its half-vector
// at cos(theta_h) = n_h.
float ggx_vndf_pdf(float n_h, float n_v, float alpha);

}  // namespace dofcache::render
