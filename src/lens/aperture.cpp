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
  // Area in [0, t] of the half-sector: the integral of rim(t)^2 / 2, by Simpson's rule per bin.
  const double half = kPi / shape_.blades;
  const auto r2 = [&](double t) {
    const double r = (1.0 - shape_.roundness) * std::cos(half) / std::cos(t) + shape_.roundness;
    return r * r;
  };
  cdf_.assign(kTableBins + 1, 0.0);
  const double dt = half / kTableBins;
  for (int i = 0; i < kTableBins; ++i) {
    const double t = i * dt;
    cdf_[i + 1] = cdf_[i] + dt / 6.0 * (r2(t) + 4.0 * r2(t + 0.5 * dt) + r2(t + dt));
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
  const double half = kPi / n;
  // Which of the 2N half-sectors, and where in it. Each spans an edge's normal to a corner; the
  // even ones are walked from the corner, so that u.x sweeps the angle continuously.
  const double scaled = static_cast<double>(u.x) * 2 * n;
  const int h = std::min(static_cast<int>(scaled), 2 * n - 1);
  const double f = h % 2 == 0 ? 1.0 - (scaled - h) : scaled - h;
  // t, the angle from the normal, with density proportional to rim(t)^2: the table's inverse.
  const auto it = std::upper_bound(cdf_.begin(), cdf_.end(), f);
  const int i = std::clamp(static_cast<int>(it - cdf_.begin()) - 1, 0, kTableBins - 1);
  const double width = cdf_[i + 1] - cdf_[i];
  const double t = (i + (width > 0 ? (f - cdf_[i]) / width : 0.0)) * half / kTableBins;
  const double normal = radians(shape_.rotation_deg) + half + 2.0 * half * (h / 2);
  const double angle = h % 2 == 0 ? normal - t : normal + t;
  const double rim_here =
      (1.0 - shape_.roundness) * std::cos(half) / std::cos(t) + shape_.roundness;
  const double r = rim_here * std::sqrt(static_cast<double>(u.y));
  return glm::vec2(static_cast<float>(r * std::cos(angle)),
                   static_cast<float>(r * std::sin(angle))) *
         squeeze_;
}

}  // namespace dofcache::lens
