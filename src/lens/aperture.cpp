#include "dofcache/lens/aperture.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "dofcache/core/error.h"
#include "dofcache/lens/thin_lens.h"

namespace dofcache::lens {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kTableBins = 1024;  // per half-sector; the density is smooth within a bin

double radians(double degrees) { return degrees * kPi / 180.0; }

}  // namespace

void ApertureShape::validate() const {
  if (blades != 0 && (blades < kMinBlades || blades > kMaxBlades))
    throw Error("lens: aperture blades must be 0 (round) or " + std::to_string(kMinBlades) + " to " +
                std::to_string(kMaxBlades) + ", got " + std::to_string(blades));
  if (!std::isfinite(rotation_deg))
    throw Error("lens: aperture rotation must be a finite angle in degrees");
  if (!(roundness >= 0.0 && roundness <= 1.0))
    throw Error("lens: aperture roundness must be in [0, 1] (0: straight blades, 1: round), got " +
                std::to_string(roundness));
  if (!(anamorphic_ratio > 0.0) || !std::isfinite(anamorphic_ratio) || anamorphic_ratio > 100.0)
    throw Error("lens: anamorphic ratio must be > 0 and at most 100 (the bokeh's height over its "
                "width), got " + std::to_string(anamorphic_ratio));
}

double ApertureShape::inner_scale() const {
  const double polygon =
      blades == 0 ? 1.0 : (1.0 - roundness) * std::cos(kPi / blades) + roundness;
  return polygon * std::min(anamorphic_ratio, 1.0 / anamorphic_ratio);
}

ApertureChoices ApertureChoices::over(const ApertureChoices& fallback) const {
  return {blades ? blades : fallback.blades,
          rotation_deg ? rotation_deg : fallback.rotation_deg,
          roundness ? roundness : fallback.roundness,
          anamorphic_ratio ? anamorphic_ratio : fallback.anamorphic_ratio};
}

ApertureShape ApertureChoices::shape() const {
  const ApertureShape round;
  return {blades.value_or(round.blades), rotation_deg.value_or(round.rotation_deg),
          roundness.value_or(round.roundness), anamorphic_ratio.value_or(round.anamorphic_ratio)};
}

Aperture::Aperture(const ApertureShape& shape) : shape_(shape) {
  shape_.validate();
  squeeze_ = glm::vec2(static_cast<float>(std::min(1.0, 1.0 / shape_.anamorphic_ratio)),
                       static_cast<float>(std::min(1.0, shape_.anamorphic_ratio)));
  if (shape_.blades == 0) return;
  const int n = shape_.blades;
  if (shape_.roundness == 0.0) {
    for (int k = 0; k <= n; ++k) {
      const double a = radians(shape_.rotation_deg) + 2.0 * kPi * k / n;
      corners_.push_back(glm::vec2(static_cast<float>(std::cos(a)),
                                   static_cast<float>(std::sin(a))) *
                         squeeze_);
    }
    return;
  }
  // Area in [0, t] of the half-sector: the integral of rim(t)^2 / 2, by Simpson's rule per bin.
  const double half = kPi / n;
  const auto rim = [&](double t) {
    return (1.0 - shape_.roundness) * std::cos(half) / std::cos(t) + shape_.roundness;
  };
  cdf_.assign(kTableBins + 1, 0.0);
  rim_.assign(kTableBins + 1, 0.0);
  cos_.assign(kTableBins + 1, 0.0);
  sin_.assign(kTableBins + 1, 0.0);
  const double dt = half / kTableBins;
  for (int i = 0; i <= kTableBins; ++i)
    rim_[i] = rim(i * dt), cos_[i] = std::cos(i * dt), sin_[i] = std::sin(i * dt);
  for (int k = 0; k < n; ++k) {
    const double a = radians(shape_.rotation_deg) + half + 2.0 * half * k;
    normals_.push_back({std::cos(a), std::sin(a)});
  }
  for (int i = 0; i < kTableBins; ++i) {
    const double mid = rim((i + 0.5) * dt);
    cdf_[i + 1] = cdf_[i] + dt / 6.0 * (rim_[i] * rim_[i] + 4.0 * mid * mid +
                                        rim_[i + 1] * rim_[i + 1]);
  }
  for (double& c : cdf_) c /= cdf_.back();
}

double Aperture::polygon_rim(double angle) const {
  if (shape_.blades == 0) return 1.0;
  const int n = shape_.blades;
  const double sector = 2.0 * kPi / n;
  // The angle from the nearest edge's normal (edge normals lie half a sector from the corners).
  double t = std::fmod(angle - radians(shape_.rotation_deg) - 0.5 * sector, sector);
  if (t < 0) t += sector;
  if (t > 0.5 * sector) t -= sector;
  return (1.0 - shape_.roundness) * std::cos(kPi / n) / std::cos(t) + shape_.roundness;
}

double Aperture::rim(double angle) const {
  // The unsqueezed direction that the squeeze turns into `angle`, and the squeezed rim point's
  // distance.
  const double sx = squeeze_.x, sy = squeeze_.y;
  const double b = std::atan2(std::sin(angle) / sy, std::cos(angle) / sx);
  const double r = polygon_rim(b);
  return r * std::hypot(sx * std::cos(b), sy * std::sin(b));
}

bool Aperture::contains(glm::vec2 p) const {
  const double x = p.x / squeeze_.x, y = p.y / squeeze_.y;
  return std::hypot(x, y) <= polygon_rim(std::atan2(y, x));
}

glm::vec2 Aperture::sample(glm::vec2 u) const {
  if (shape_.blades == 0) return concentric_disk(u) * squeeze_;
  const int n = shape_.blades;
  if (!corners_.empty()) {
    // The triangle (centre, corner k, corner k + 1), uniformly: sqrt(u.y) of the way out, at a
    // fraction along the edge.
    const float scaled = u.x * static_cast<float>(n);
    const int k = std::min(static_cast<int>(scaled), n - 1);
    const float along = scaled - static_cast<float>(k);
    const float out = std::sqrt(u.y);
    return out * ((1.0f - along) * corners_[k] + along * corners_[k + 1]);
  }
  // Which of the 2N half-sectors, and where in it. Each spans an edge's normal to a corner; the
  // even ones are walked from the corner, so that u.x sweeps the angle continuously.
  const double scaled = static_cast<double>(u.x) * 2 * n;
  const int h = std::min(static_cast<int>(scaled), 2 * n - 1);
  const double f = h % 2 == 0 ? 1.0 - (scaled - h) : scaled - h;
  // t, the angle from the normal, with density proportional to rim(t)^2: the table's inverse.
  // The density varies little within a half-sector, so the bin is found near f's own.
  int i = std::clamp(static_cast<int>(f * kTableBins), 0, kTableBins - 1);
  while (i > 0 && cdf_[i] > f) --i;
  while (i < kTableBins - 1 && cdf_[i + 1] <= f) ++i;
  const double width = cdf_[i + 1] - cdf_[i];
  const double w = width > 0 ? (f - cdf_[i]) / width : 0.0;
  // The direction at t from the edge's normal, turned towards the half-sector's corner: the
  // tables interpolated (bins of at most 0.06 degrees: errors under 1e-7) instead of sin and cos.
  const double c = cos_[i] + w * (cos_[i + 1] - cos_[i]);
  const double s = (h % 2 == 0 ? -1.0 : 1.0) * (sin_[i] + w * (sin_[i + 1] - sin_[i]));
  const glm::dvec2 nd = normals_[h / 2];
  const double r = (rim_[i] + w * (rim_[i + 1] - rim_[i])) * std::sqrt(static_cast<double>(u.y));
  return glm::vec2(static_cast<float>(r * (nd.x * c - nd.y * s)),
                   static_cast<float>(r * (nd.y * c + nd.x * s))) *
         squeeze_;
}

}  // namespace dofcache::lens
