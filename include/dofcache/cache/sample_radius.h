#pragma once
// Depth-dependent validity radius of a cache sample (paper section 4.1, eqs. 4.1 and 4.2).
#include "dofcache/lens/thin_lens.h"

namespace dofcache::cache {

// radius(D) = factor1(D) * max(factor2(D), min_factor), D the depth of the hit point along the
// optical axis (camera-space z, not the ray length).
//   factor1, eq. (4.1): the footprint of one pixel at depth D, (i_height / y_res) (D / V_P).
//   factor2, eq. (4.2) as read in the digest: the circle-of-confusion radius at depth D in pixels
//     (the cone radius of eq. 2.5 divided by factor1, i.e. LensImaging::coc_radius_pixels).
// In focus a sample therefore covers min_factor of a pixel footprint (0.5: "only within one
// pixel"); out of focus it covers its circle of confusion, so blurred regions are cached sparsely.
double sample_radius(const lens::LensImaging& imaging, double depth, double min_factor = 0.5);

}  // namespace dofcache::cache
