#include "aperture_rows.h"

#include <algorithm>
#include <cmath>

namespace dofcache::preview::detail {

ApertureRows::ApertureRows(const lens::Aperture& aperture, int rows, int columns) : rows_(rows) {
  first_.reserve(rows + 2);
  auto inside = [&](float x, float y) { return aperture.contains({x, y}); };
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

}  // namespace dofcache::preview::detail
