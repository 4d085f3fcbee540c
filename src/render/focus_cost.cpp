#include "dofcache/render/focus_cost.h"

#include <algorithm>
#include <cmath>

namespace dofcache::render {

double focus_sample_growth(std::uint32_t measured_spp, std::uint32_t spp) {
  if (measured_spp == 0 || spp <= measured_spp) return 1.0;
  return 1.0 + 0.2 * std::log2(static_cast<double>(spp) / measured_spp);
}

double focus_cost_ratio(const FocusCost& m, std::uint32_t measured_spp, std::uint32_t spp) {
  if (m.lookups == 0 || m.samples == 0 || m.direct_shades == 0 || m.direct_rays == 0 ||
      measured_spp == 0)
    return 0.0;
  const double direct_rays =
      static_cast<double>(m.direct_rays) / static_cast<double>(m.direct_shades);
  // Lookups grow as the lens samples; the samples' rays as the samples do.
  const double lookups =
      static_cast<double>(m.lookups) * std::max(spp, measured_spp) / measured_spp;
  const double rays = static_cast<double>(m.rays) * focus_sample_growth(measured_spp, spp);
  return rays / lookups / direct_rays;
}

}  // namespace dofcache::render
