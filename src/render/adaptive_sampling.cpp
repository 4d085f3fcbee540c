#include "dofcache/render/adaptive_sampling.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "dofcache/core/error.h"
#include "dofcache/core/rng.h"

namespace dofcache::render {
namespace {

// The relative variance's floor on the squared mean, as the relative MSE the benchmarks report:
// dark pixels are judged by absolute, not relative, noise.
constexpr double kRelativeEpsilon = 1e-2;

double relative_variance(const PixelMoments& m) {
  if (m.count < 2) return 0.0;
  const double n = m.count, mean = m.sum / n;
  const double variance = std::max(0.0, (m.sum2 - m.sum * mean) / (n - 1.0));
  return variance / (mean * mean + kRelativeEpsilon);
}

}  // namespace

void AdaptiveSampling::validate() const {
  if (min_pilot < 1 || min_pilot > 1024)
    throw Error("adaptive sampling: the pilot's samples per pixel must be in [1, 1024]");
  if (!(pilot_fraction > 0.0f && pilot_fraction <= 1.0f))
    throw Error("adaptive sampling: the pilot's fraction of the samples must be in (0, 1]");
  if (!(min_factor >= 0.0f && min_factor <= 1.0f))
    throw Error("adaptive sampling: the smallest factor of the mean must be in [0, 1]");
  if (!(max_factor >= 1.0f && max_factor <= 1024.0f))
    throw Error("adaptive sampling: the largest factor over the mean must be in [1, 1024]");
}

std::uint32_t pilot_samples(const AdaptiveSampling& a, int spp) {
  if (!a.enabled || spp < 4) return 0;
  // Below 2 * min_pilot the pilot is half the samples: read over a 3x3 neighbourhood, a pilot of
  // 2 or 4 still finds the few pixels that hold most of the noise (docs/design.md).
  const double wanted = std::max<double>(std::min(a.min_pilot, spp / 2),
                                         std::floor(spp * double(a.pilot_fraction)));
  std::uint32_t pilot = 1;
  while (2.0 * pilot <= wanted) pilot *= 2;  // a power of two: a whole prefix of the Sobol points
  return pilot >= 2 && pilot < static_cast<std::uint32_t>(spp) ? pilot : 0;
}

std::vector<std::uint32_t> allocate_samples(const std::vector<PixelMoments>& pilot,
                                            const std::vector<char>& rendered, int width,
                                            int height, int spp, const AdaptiveSampling& a,
                                            std::uint64_t seed) {
  const std::size_t n = static_cast<std::size_t>(width) * height;
  std::vector<double> variance(n, 0.0);
  for (std::size_t i = 0; i < n; ++i)
    if (rendered[i]) variance[i] = relative_variance(pilot[i]);

  // Each pixel's share from its 3x3 neighbourhood: robust to a pilot that happened to agree with
  // itself, and little correlated with the pixel's own estimate.
  std::vector<double> share(n, 0.0), base(n, 0.0);
  double share_sum = 0.0, budget = 0.0;
  std::size_t count = 0;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * width + x;
      if (!rendered[i]) continue;
      double sum = 0.0;
      int k = 0;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int xx = x + dx, yy = y + dy;
          if (xx < 0 || yy < 0 || xx >= width || yy >= height) continue;
          const std::size_t j = static_cast<std::size_t>(yy) * width + xx;
          if (rendered[j]) sum += variance[j], ++k;
        }
      share[i] = std::sqrt(sum / k);
      share_sum += share[i];
      base[i] = std::max<double>(pilot[i].count, std::floor(double(a.min_factor) * spp));
      budget += spp - base[i];
      ++count;
    }
  if (count == 0) return std::vector<std::uint32_t>(n, 0);
  // A floor, so that a budget the noisy pixels cannot take (their cap) goes to the others.
  const double floor = share_sum > 0.0 ? 1e-3 * share_sum / count : 1.0;
  for (std::size_t i = 0; i < n; ++i)
    if (rendered[i]) share[i] = std::max(share[i], floor);

  // Water-filling: extra_i = min(cap_i, lambda share_i) with the extras summing to the budget.
  const double cap = double(a.max_factor) * spp;
  std::vector<double> extra(n, 0.0);
  std::vector<char> capped(n, 0);
  double remaining = budget;
  for (int round = 0; round < 64; ++round) {
    double free_share = 0.0;
    for (std::size_t i = 0; i < n; ++i)
      if (rendered[i] && !capped[i]) free_share += share[i];
    if (!(free_share > 0.0)) break;
    const double lambda = remaining / free_share;
    bool newly_capped = false;
    for (std::size_t i = 0; i < n; ++i) {
      if (!rendered[i] || capped[i]) continue;
      const double headroom = cap - base[i];
      if (lambda * share[i] >= headroom) {
        extra[i] = std::max(0.0, headroom);
        capped[i] = 1;
        remaining -= extra[i];
        newly_capped = true;
      }
    }
    if (newly_capped) continue;
    for (std::size_t i = 0; i < n; ++i)
      if (rendered[i] && !capped[i]) extra[i] = lambda * share[i];
    break;
  }

  std::vector<std::uint32_t> samples(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    if (!rendered[i]) continue;
    const double whole = std::floor(extra[i]);
    const double dither =
        static_cast<double>(mix64(hash_combine(seed, i)) >> 40) * 0x1p-24;  // in [0, 1)
    samples[i] = static_cast<std::uint32_t>(base[i] + whole) +
                 (dither < extra[i] - whole ? 1u : 0u);
  }
  return samples;
}

}  // namespace dofcache::render
