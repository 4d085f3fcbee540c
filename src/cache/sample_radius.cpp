#include "dofcache/cache/sample_radius.h"

#include <algorithm>

namespace dofcache::cache {

double sample_radius(const lens::LensImaging& imaging, double depth, double min_factor) {
  double factor1 = imaging.pixel_footprint(depth);     // eq. (4.1)
  double factor2 = imaging.coc_radius_pixels(depth);   // eq. (4.2), read as CoC radius in pixels
  return factor1 * std::max(factor2, min_factor);
}

}  // namespace dofcache::cache
