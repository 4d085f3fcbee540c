#pragma once
// Internal: the aperture's shape as horizontal spans per row, so that the shaped scatter draws it
// at any size without testing every pixel of every splat against the shape.
#include <functional>
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
  // with inside(x, y) and bisecting each crossing to 1e-4 (a rounded blade, an oval, an aperture
  // image's runs, a ring of a transmission profile).
  ApertureRows(const std::function<bool(float, float)>& inside, int rows = 256,
               int columns = 512);
  // The aperture's shape (Aperture::contains).
  explicit ApertureRows(const lens::Aperture& aperture, int rows = 256, int columns = 512);
  // The spans of the row nearest height y (aperture units, up), left to right; none outside.
  const ApertureSpan* begin(float y) const { return spans_.data() + first_[row(y)]; }
  const ApertureSpan* end(float y) const { return spans_.data() + first_[row(y) + 1]; }
  // The share of the aperture's area inside every present disc of `stops` (aperture units): the
  // light a vignetting stop, or a real lens's rims, let through.
  float area_share(const render::StopDisc (&stops)[2]) const;
  double area() const { return area_; }  // the spans' summed length

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

// A transmission over the aperture (a profile, an aperture image's grey levels: Aperture::pass)
// as a layer cake: level k holds the points that pass at least its threshold and weighs the step
// from the threshold below, so the levels' weighted sum is the transmission with its values
// rounded to the thresholds. An image of a few grey levels has them as its thresholds (exact);
// a profile, or an image of many, `kLevels` steps of 1 / kLevels (values rounded to the nearest).
// An aperture that passes all or nothing (blades, an oval) is one level, the shape itself.
class ApertureLevels {
 public:
  static constexpr int kLevels = 4;
  explicit ApertureLevels(const lens::Aperture& aperture);
  const ApertureRows& shape() const { return shape_; }  // where it passes anything: coverage
  int count() const { return levels_.empty() ? 1 : static_cast<int>(levels_.size()); }
  const ApertureRows& level(int k) const { return levels_.empty() ? shape_ : levels_[k]; }
  float weight(int k) const { return levels_.empty() ? 1.0f : weights_[k]; }
  // The levels' weighted area over the shape's: the transmission's mean over the shape.
  double mean() const { return mean_; }
  // The light the stops' discs let through, as a share of the transmission's.
  float area_share(const render::StopDisc (&stops)[2]) const;

 private:
  ApertureRows shape_;
  std::vector<ApertureRows> levels_;  // none where it passes all or nothing (the shape)
  std::vector<float> weights_;
  double mean_ = 1.0;
};

}  // namespace dofcache::preview::detail
