#pragma once
// Lens samples spread by measured noise. With the radiance cache, a lens ray's lighting is nearly
// noise free; what noise remains is visibility through the lens, and it sits where the blur of an
// out-of-focus edge mixes surfaces: on the Cornell box at f/0.7 a tenth of the pixels held 81% of
// the variance of a uniformly sampled image. A pilot of a few samples per pixel measures each
// pixel's relative variance; the rest of the budget (the same total as uniform sampling) goes to
// the pixels in proportion to their relative standard deviation, the allocation that minimises
// the summed relative variance sum_i s_i^2 / n_i for a fixed sum_i n_i.
//
// The pilot's samples stay in the pixel's average. Choosing n_i from the same samples correlates
// the count with the estimate slightly (as any adaptive sampler's stopping rule does); the
// allocation reads a 3x3 neighbourhood's variance, not the pixel's own, which keeps that
// correlation small (measured: docs/design.md, "Adaptive lens sampling").
#include <cstdint>
#include <vector>

namespace dofcache::render {

struct AdaptiveSampling {
  bool enabled = false;
  int min_pilot = 8;  // pilot samples per pixel at least, or half the samples if fewer (from 4 spp)
  float pilot_fraction = 0.25f;  // of the budget; rounded down to a power of two
  float max_factor = 8.0f;   // no pixel gets more than max_factor x the mean samples per pixel
  float min_factor = 0.5f;   // nor fewer than min_factor x the mean (or the pilot if more)

  void validate() const;  // throws dofcache::Error on absurd values
};

// Running sums of one pixel's sample luminance.
struct PixelMoments {
  double sum = 0.0, sum2 = 0.0;
  std::uint32_t count = 0;
};

// The pilot's samples per pixel for `spp` samples per pixel on average; 0: sample uniformly.
std::uint32_t pilot_samples(const AdaptiveSampling& a, int spp);

// Total samples for each pixel (row-major; pilot included) so that the pixels with `rendered`
// set share spp x their count in all, each at least its pilot and at most max_factor x spp.
// Counts are whole numbers, the fractions dithered by a hash of (seed, pixel), so the total
// matches the budget on average. Deterministic.
std::vector<std::uint32_t> allocate_samples(const std::vector<PixelMoments>& pilot,
                                            const std::vector<char>& rendered, int width,
                                            int height, int spp, const AdaptiveSampling& a,
                                            std::uint64_t seed);

}  // namespace dofcache::render
