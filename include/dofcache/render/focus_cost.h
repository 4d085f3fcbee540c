#pragma once
// Whether a cached render's in-focus hits go through the cache or are shaded per ray, decided
// from what the render's first lens samples measured rather than assumed.
//
// In focus a sample covers about one pixel footprint, so it is reused by few lens rays (measured
// at 16 spp: 8-13 lookups per sample on the five peer scenes, 9 on the atrium), while its cost
// (CacheSettings::sample_quality times the per-ray budget, again for every refinement round)
// grows with the lens samples as its reuse does. Whether it pays therefore depends on the scene,
// not on spp: on the small peer scenes an in-focus lookup costs 0.65-1.9 per-ray shades' rays;
// on the atrium at 16 spp, whose estimators disagree among leaves, flutes and skylight mullions,
// 2.5 (160 rays per sample, reused 9 times), and per-ray shading is 3.3x faster at a lower error
// (docs/cache.md, "In focus at any lens count: measured per render, not assumed").
#include <cstdint>

namespace dofcache::render {

// What the in-focus hits' cache samples cost over the render's first lens samples.
struct FocusCost {
  std::uint64_t lookups = 0;  // in-focus hits looked up in the cache
  std::uint64_t samples = 0;  // new samples they made
  std::uint64_t rays = 0;     // rays those samples cast, refinement rounds included
  std::uint64_t direct_shades = 0;  // in-focus hits shaded per ray meanwhile (other tiles)
  std::uint64_t direct_rays = 0;    // the rays they cast

  FocusCost& operator+=(const FocusCost& o) {
    lookups += o.lookups, samples += o.samples, rays += o.rays;
    direct_shades += o.direct_shades, direct_rays += o.direct_rays;
    return *this;
  }
};

// The lens samples after which the cost is measured and the choice made.
constexpr std::uint32_t kFocusCostSamples = 2;

// How much the in-focus samples grow from `measured_spp` to `spp` lens samples: as more lens rays
// land, fewer find no sample near them. Measured from 2 to 16 spp: 1.46x on the Cornell box, 1.54x
// on the hanging-light room, 1.73x on the atrium; from 2 to 4: 1.20-1.28x. 1 + 0.2 log2 of the
// ratio (1.6 from 2 to 16).
double focus_sample_growth(std::uint32_t measured_spp, std::uint32_t spp);

// The rays an in-focus lookup will have cost by the end of a render of `spp` lens samples per
// pixel (its samples' rays over all lookups, projected from `measured_spp` by the lookups' and the
// samples' growth), over the rays of one per-ray shade as measured. 0 when either was not
// measured.
double focus_cost_ratio(const FocusCost& measured, std::uint32_t measured_spp, std::uint32_t spp);

}  // namespace dofcache::render
