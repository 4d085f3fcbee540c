#pragma once
// Internal: the aperture's shape as horizontal spans per row, so that the shaped scatter draws it
// at any size without testing every pixel of every splat against the shape.
#include <vector>

#include "dofcache/lens/aperture.h"
#include "dofcache/render/camera.h"

namespace dofcache::preview::detail {

struct ApertureSpan {
  float x0, x1;  // aperture units (the round aperture's radius), x0 <= x1
};

class ApertureRows {
 public:
  // `rows` rows over y in [-1, 1]; each row's spans found by testing `columns` points along it
  // with Aperture::contains and bisecting each crossing to 1e-4 (a rounded blade, an oval, an
  // aperture image's runs).
  explicit ApertureRows(const lens::Aperture& aperture, int rows = 256, int columns = 512);
  // The spans of the row nearest height y (aperture units, up), left to right; none outside.
  const ApertureSpan* begin(float y) const { return spans_.data() + first_[row(y)]; }
  const ApertureSpan* end(float y) const { return spans_.data() + first_[row(y) + 1]; }
  // The share of the aperture's area inside every present disc of `stops` (aperture units): the
  // light a vignetting stop, or a real lens's rims, let through.
  float area_share(const render::StopDisc (&stops)[2]) const;

 private:
  int row(float y) const {  // an empty sentinel row (index rows_) outside [-1, 1]
    const float f = (y + 1.0f) * 0.5f * static_cast<float>(rows_);
    return f >= 0.0f && f < static_cast<float>(rows_) ? static_cast<int>(f) : rows_;
  }
  float row_centre(int i) const {  // the height of row i's centre
    return -1.0f + (static_cast<float>(i) + 0.5f) * 2.0f / static_cast<float>(rows_);
  }
  int rows_;
  std::vector<int> first_;  // rows_ + 2 offsets into spans_
  std::vector<ApertureSpan> spans_;
  double area_ = 0;  // the spans' summed length
};

}  // namespace dofcache::preview::detail
