#pragma once
// The value types of the radiance cache: what a sample holds, how a lookup is configured, and
// what it returns. Small and passed by value or const reference; no behaviour here.
#include <cstdint>
#include <vector>

#include <glm/vec3.hpp>

namespace dofcache::cache {

// One cached shading result (paper, Algorithm 1: `sample{R, hit.P, hit.N, radius}`).
//
// `value` is the diffuse, view-independent part of the outgoing radiance with the albedo factored
// out: E / pi in RGB, E the irradiance. The renderer multiplies it by the albedo at the point it
// shades, so textures stay as sharp as the pixel grid while the slowly varying illumination is
// interpolated. Emitted radiance and specular lobes are view dependent and are never cached.
struct CacheSample {
  glm::vec3 position{0.0f};
  glm::vec3 normal{0.0f, 0.0f, 1.0f};  // unit length
  glm::vec3 value{0.0f};               // E / pi, RGB
  float radius = 0.0f;                 // world-space validity radius, see sample_radius.h
  std::uint32_t frame = 0;             // frame of a camera path that created it (set by the caller)
  // Stable identity, assigned by RadianceCache::insert in a canonical order and kept until the
  // sample is evicted. Lookups sum in increasing id, which makes them bit-identical across
  // backends and thread counts; it is also the handle for per-frame usage tracking and eviction.
  std::uint32_t id = 0;
};

struct LookupOptions {
  // Reject samples whose normal is more than this many degrees from the query normal. Eq. (4.3)
  // alone only shrinks a sample's reach by 1/(n . n_i) (10% at 25 degrees), so creases need an
  // explicit cut. 25 degrees keeps reuse across the facets of tessellated curved surfaces (a
  // 32-segment sphere has 11.25 degrees between facets) and rejects box edges and sharper creases.
  float max_normal_angle_deg = 25.0f;
  // A lookup succeeds when at least this many samples are accepted (the paper: one is enough on
  // diffuse surfaces).
  int min_samples = 1;
  // Reject samples lying in front of the query point's tangent plane (Ward's test, as in Mitsuba):
  // (p - p_i) . (n + n_i) / 2 < -front_tolerance * r_i. Such a sample sits on a step or ledge
  // above the query point and saw light the query point may not see (for example the top of a
  // book next to its shadow on the table). The averaged normal makes the test exactly neutral on
  // spheres, so it does not cost reuse on concave curved surfaces.
  bool reject_in_front = true;
  float front_tolerance = 0.05f;  // fraction of the sample radius
  // An anisotropic footprint: an anamorphic aperture's bokeh is an oval (lens/aperture.h), so a
  // sample's radius r is the oval's larger semi-axis and along the smaller, the frame camera's
  // unit axis `footprint_axis`, it reaches max(footprint_squeeze r, the in-focus floor), the floor
  // being floor_per_depth times the query's depth along camera_forward from camera_position
  // (min_factor pixel footprints: a sample in focus is round). Squeeze 1 (the default): the
  // paper's sphere. Set per frame by the renderer from its camera, not by a request.
  float footprint_squeeze = 1.0f;
  glm::vec3 footprint_axis{1.0f, 0.0f, 0.0f};
  glm::vec3 camera_position{0.0f}, camera_forward{0.0f, 0.0f, -1.0f};
  float floor_per_depth = 0.0f;
  bool anisotropic() const { return footprint_squeeze < 1.0f; }
};

struct LookupResult {
  glm::vec3 value{0.0f};   // sum w_i v_i / sum w_i over the accepted samples (0 if none)
  float weight_sum = 0.0f;  // sum w_i
  int count = 0;            // number of accepted samples
  // Input: when set, the lookup appends the ids of the accepted samples, in increasing order, even
  // if there are fewer than min_samples (per-frame usage tracking, eviction). Left unchanged.
  std::vector<std::uint32_t>* accepted_ids = nullptr;
};

}  // namespace dofcache::cache
