#include "aperture_rows.h"

#include <algorithm>
#include <cmath>

namespace dofcache::preview::detail {

ApertureRows::ApertureRows(const lens::Aperture& aperture, int rows, int columns)
    : ApertureRows([&](float x, float y) { return aperture.contains({x, y}); }, rows, columns) {}

ApertureRows::ApertureRows(const std::function<bool(float, float)>& inside, int rows, int columns)
    : rows_(rows) {
  first_.reserve(rows + 2);
  // The crossing between a (inside == ia) and b: bisected.
  auto crossing = [&](float a, float b, float y, bool ia) {
    for (int k = 0; k < 14 && b - a > 1e-4f; ++k) {
      const float m = 0.5f * (a + b);
      (inside(m, y) == ia ? a : b) = m;
    }
    return 0.5f * (a + b);
  };
  const float dx = 2.0f / static_cast<float>(columns);
  for (int i = 0; i < rows; ++i) {
    first_.push_back(static_cast<int>(spans_.size()));
    const float y = row_centre(i);
    float prev_x = -1.0f;
    bool prev = inside(prev_x, y);
    float start = prev ? -1.0f : 0.0f;
    for (int c = 1; c <= columns; ++c) {
      const float x = -1.0f + static_cast<float>(c) * dx;
      const bool now = inside(x, y);
      if (now != prev) {
        const float at = crossing(prev_x, x, y, prev);
        if (now)
          start = at;
        else
          spans_.push_back({start, at});
      }
      prev = now;
      prev_x = x;
    }
    if (prev) spans_.push_back({start, 1.0f});
  }
  first_.push_back(static_cast<int>(spans_.size()));
  first_.push_back(static_cast<int>(spans_.size()));  // the empty sentinel row
  for (const ApertureSpan& s : spans_) area_ += s.x1 - s.x0;
}

float ApertureRows::area_share(const render::StopDisc (&stops)[2]) const {
  // A disc holding [-1, 1]^2 clips nothing.
  auto clips = [](const render::StopDisc& d) {
    return d.present() && std::hypot(d.centre.x, d.centre.y) + 1.5f > d.radius;
  };
  if (area_ <= 0.0 || (!clips(stops[0]) && !clips(stops[1]))) return 1.0f;
  double inside = 0;
  for (int i = 0; i < rows_; ++i) {
    const float yi = row_centre(i);
    float lo = -2.0f, hi = 2.0f;  // the row's chord through every disc
    for (const render::StopDisc& d : stops) {
      if (!d.present()) continue;
      const float h2 = d.radius * d.radius - (yi - d.centre.y) * (yi - d.centre.y);
      const float h = std::sqrt(std::max(0.0f, h2));
      lo = std::max(lo, h2 > 0.0f ? d.centre.x - h : 2.0f);
      hi = std::min(hi, d.centre.x + h);
    }
    if (lo >= hi) continue;
    for (int k = first_[i]; k < first_[i + 1]; ++k)
      inside += std::max(0.0f, std::min(spans_[k].x1, hi) - std::max(spans_[k].x0, lo));
  }
  return static_cast<float>(inside / area_);
}

namespace {
bool graded(const lens::ApertureShape& s) { return s.weighted() || !s.image.empty(); }

// The thresholds of the levels and their weights: the distinct values the aperture passes where
// they are few (sampled on a grid), else steps of 1 / ApertureLevels::kLevels.
void thresholds(const lens::Aperture& aperture, std::vector<double>& at, std::vector<float>& w) {
  constexpr int kGrid = 256;
  std::vector<double> values;
  for (int j = 0; j < kGrid; ++j)
    for (int i = 0; i < kGrid; ++i) {
      const double v = aperture.pass({-1.0f + (2.0f * i + 1.0f) / kGrid,
                                      -1.0f + (2.0f * j + 1.0f) / kGrid});
      if (v > 0.0) values.push_back(v);
    }
  std::sort(values.begin(), values.end());
  values.erase(std::unique(values.begin(), values.end(),
                           [](double a, double b) { return b - a < 1e-6; }),
               values.end());
  if (values.size() <= static_cast<std::size_t>(ApertureLevels::kLevels)) {
    double below = 0;
    for (double v : values) {
      at.push_back(v - 1e-7);  // the level's own value passes
      w.push_back(static_cast<float>(v - below));
      below = v;
    }
    return;
  }
  for (int k = 0; k < ApertureLevels::kLevels; ++k) {
    at.push_back((k + 0.5) / ApertureLevels::kLevels);
    w.push_back(1.0f / ApertureLevels::kLevels);
  }
}
}  // namespace

ApertureLevels::ApertureLevels(const lens::Aperture& aperture) : shape_(aperture) {
  if (!graded(aperture.shape())) return;
  std::vector<double> at;
  thresholds(aperture, at, weights_);
  levels_.reserve(at.size());
  double weighted = 0;
  for (std::size_t k = 0; k < at.size(); ++k) {
    const double t = at[k];
    levels_.emplace_back([&](float x, float y) { return aperture.pass({x, y}) >= t; });
    weighted += weights_[k] * levels_.back().area();
  }
  if (shape_.area() > 0.0) mean_ = weighted / shape_.area();
}

float ApertureLevels::area_share(const render::StopDisc (&stops)[2]) const {
  if (levels_.empty()) return shape_.area_share(stops);
  double passed = 0, total = 0;
  for (std::size_t k = 0; k < levels_.size(); ++k) {
    passed += weights_[k] * levels_[k].area_share(stops) * levels_[k].area();
    total += weights_[k] * levels_[k].area();
  }
  return total > 0.0 ? static_cast<float>(passed / total) : 1.0f;
}

}  // namespace dofcache::preview::detail
