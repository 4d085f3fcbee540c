#include "dofcache/cache/sample_radius.h"

#include <algorithm>
#include <cmath>

#include "dofcache/core/error.h"

namespace dofcache::cache {

double sample_radius_pixels(const lens::LensImaging& imaging, double depth, double min_factor) {
  // eq. (4.2), CoC in pixels; a shaped aperture's bokeh reaches its polygon's inradius (1 for the
  // round one) along its larger axis, and the lookup's anisotropic footprint shortens the smaller
  // (anisotropic_footprint), so a sample is never reused beyond what the blur hides.
  return std::max(imaging.coc_radius_pixels(depth) * imaging.lens.aperture.footprint_scale(),
                  min_factor);
}

double sample_radius(const lens::LensImaging& imaging, double depth, double min_factor) {
  // eq. (4.1): the pixel footprint, times eq. (4.2)'s factor
  return imaging.pixel_footprint(depth) * sample_radius_pixels(imaging, depth, min_factor);
}

RadiusRule parse_radius_rule(const std::string& name) {
  if (name == "paper") return RadiusRule::Paper;
  if (name == "adaptive") return RadiusRule::Adaptive;
  throw Error("unknown cache radius rule '" + name + "' (valid: paper, adaptive)");
}

const char* radius_rule_name(RadiusRule rule) {
  switch (rule) {
    case RadiusRule::Paper: return "paper";
    case RadiusRule::Adaptive: return "adaptive";
  }
  return "?";
}

void RadiusSettings::validate() const {
  if (!std::isfinite(min_factor) || min_factor <= 0.0 || min_factor > 1e4)
    throw Error("cache min factor must be a positive number, got " + std::to_string(min_factor));
  if (!(accuracy > 0.0 && accuracy <= 10.0)) throw Error("cache accuracy must be in (0, 10]");
  if (!(max_radius_pixels >= 0.0 && max_radius_pixels <= 1e4))
    throw Error("cache maximum radius must be in [0, 10000] pixels");
}

RadiusOrigin new_sample_radius(const RadiusSettings& settings, const lens::LensImaging& imaging,
                               double depth, double smooth_distance) {
  const double view = sample_radius(imaging, depth, settings.min_factor);
  const double footprint = imaging.pixel_footprint(depth);
  double radius = view;
  if (settings.rule == RadiusRule::Adaptive) {
    const double cap = settings.max_radius_pixels * footprint;
    radius = std::max(radius, std::min(settings.accuracy * smooth_distance, cap));
  }
  return {static_cast<float>(radius), static_cast<float>(view), static_cast<float>(footprint)};
}

RadiusOrigin radius_origin(float radius, const lens::LensImaging& imaging, double depth,
                           double min_factor) {
  if (!(depth > imaging.lens.focal_length)) return {radius, radius, 0.0f};
  return {radius, static_cast<float>(sample_radius(imaging, depth, min_factor)),
          static_cast<float>(imaging.pixel_footprint(depth))};
}

float reuse_radius(const RadiusOrigin& origin, float current, const lens::LensImaging& imaging,
                   double depth, double min_factor) {
  // Behind the lens or nearer than the focal length: no image forms there, the frame cannot see
  // the sample; leave it as it is.
  if (!(depth > imaging.lens.focal_length)) return current;
  auto required = static_cast<float>(sample_radius(imaging, depth, min_factor));
  if (!(required > 0.0f) || !std::isfinite(required)) return current;
  float r = std::min(origin.radius, required);
  if (origin.widened() && origin.footprint > 0.0f) {
    auto scale = static_cast<float>(imaging.pixel_footprint(depth) / origin.footprint);
    r = std::max(r, std::min(origin.radius, origin.radius * scale));
  }
  return r;
}

}  // namespace dofcache::cache
