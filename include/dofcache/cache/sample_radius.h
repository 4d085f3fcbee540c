#pragma once
// The validity radius of a cache sample, in one place: the paper's rule (section 4.1, eqs. 4.1 and
// 4.2), the adaptive widening, and the reuse rule that adapts a kept sample's radius to another
// camera (paper section 5, persistent caches).
#include <string>

#include "dofcache/lens/thin_lens.h"

namespace dofcache::cache {

// radius(D) = factor1(D) * max(factor2(D), min_factor), D the depth of the hit point along the
// optical axis (camera-space z, not the ray length).
//   factor1, eq. (4.1): the footprint of one pixel at depth D, (i_height / y_res) (D / V_P).
//   factor2, eq. (4.2) as read in the digest: the circle-of-confusion radius at depth D in pixels
//     (the cone radius of eq. 2.5 divided by factor1, i.e. LensImaging::coc_radius_pixels),
//     times the aperture's inner scale: the bokeh's inradius for a shaped aperture (aperture.h).
// In focus a sample therefore covers min_factor of a pixel footprint (0.5: "only within one
// pixel"); out of focus it covers its circle of confusion, so blurred regions are cached sparsely.
double sample_radius(const lens::LensImaging& imaging, double depth, double min_factor = 0.5);
// The same radius in pixel footprints: max(factor2(D), min_factor).
double sample_radius_pixels(const lens::LensImaging& imaging, double depth,
                            double min_factor = 0.5);

// How far a new cache sample may be reused.
//   paper:    sample_radius above: in focus, min_factor pixel footprints, so every in-focus pixel
//             pays about one full shade.
//   adaptive: the paper's radius as a floor, widened where the illumination is smooth: up to
//             `accuracy` times the distance over which it is known to be smooth (the renderer
//             passes the harmonic mean distance its gather rays measured, Ward's split-sphere
//             bound, and no more than the distance to the nearest light), capped at
//             `max_radius_pixels` pixel footprints. The albedo is applied per hit, so textures
//             stay sharp; only the illumination is interpolated farther.
enum class RadiusRule { Paper, Adaptive };
RadiusRule parse_radius_rule(const std::string& name);  // "paper", "adaptive"; else Error
const char* radius_rule_name(RadiusRule rule);

// Algorithm 1's minFactor: the paper's 0.5 (in focus, half a pixel footprint), which camera paths
// keep (their cache files record it); and the whole footprint single images use: a lens ray lands
// anywhere in its pixel, so half-pixel samples are each used by about one pixel (Table 4.2 of the
// paper found 1.0 faster too). Measured at 160x120 with adaptive sampling: relMSE x rays
// 1.2-1.4x lower on the Cornell box, colour bars and glossy close-up at 16 and 64 spp.
constexpr double kPaperMinFactor = 0.5;
constexpr double kSingleImageMinFactor = 1.0;

struct RadiusSettings {
  RadiusRule rule = RadiusRule::Paper;
  double min_factor = kPaperMinFactor;
  double accuracy = 0.1;           // adaptive rule: fraction of the smooth distance
  double max_radius_pixels = 8.0;  // adaptive rule: cap, in pixel footprints
  void validate() const;           // throws dofcache::Error naming the bad value
};

// The radius a sample gets when it is made, and what it was made from: what a persistent cache
// keeps to adapt the radius to later cameras.
struct RadiusOrigin {
  float radius = 0.0f;       // the radius given to the sample
  float view_radius = 0.0f;  // sample_radius() alone, before any widening
  float footprint = 0.0f;    // eq. (4.1)'s factor1 at the sample's depth
  bool widened() const { return radius > view_radius; }
};

// A new sample at `depth` seen through `imaging`. `smooth_distance` is used by the adaptive rule
// only (pass 0 under the paper rule).
RadiusOrigin new_sample_radius(const RadiusSettings& settings, const lens::LensImaging& imaging,
                               double depth, double smooth_distance);

// The origin of a sample of radius `radius` made at `depth` through `imaging` under min_factor,
// as new_sample_radius gives it (view_radius = radius and no footprint where that camera could not
// see it: depth not beyond the focal length).
RadiusOrigin radius_origin(float radius, const lens::LensImaging& imaging, double depth,
                           double min_factor);

// The reuse rule: the radius a kept sample gets in a frame that sees it at `depth` through
// `imaging` (`current` if that camera cannot see it: depth not beyond the focal length).
//   r = min(origin.radius, sample_radius(new camera, depth)).
// Where the new frame needs samples denser than the sample's radius (closer, more magnified, or
// brought into focus) it shrinks to exactly the radius a sample made now would get, so a sample
// created out of focus is used only within min_factor pixel footprints once the focus moves onto
// it; where the new frame is blurrier it grows back, but never beyond the radius it was made with
// (growing further would be as valid, but would let every lookup accept many more samples and
// slow lookups down). A sample widened when it was made keeps that widening, which is a property
// of the scene, scaled down where the new frame's pixel footprint is smaller:
//   r = max(r, min(origin.radius, origin.radius * footprint_new / origin.footprint)).
float reuse_radius(const RadiusOrigin& origin, float current, const lens::LensImaging& imaging,
                   double depth, double min_factor);

}  // namespace dofcache::cache
