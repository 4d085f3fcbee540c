#pragma once
// A float image with interleaved channels, row-major from the top-left pixel. Colour images are
// linear RGB (3 channels); depth is 1 channel; normals 3.
#include <cassert>
#include <cstddef>
#include <vector>

namespace dofcache::image {

class Image {
 public:
  Image() = default;
  Image(int width, int height, int channels, float fill = 0.0f)
      : width_(width), height_(height), channels_(channels),
        data_(static_cast<size_t>(width) * height * channels, fill) {}

  int width() const { return width_; }
  int height() const { return height_; }
  int channels() const { return channels_; }
  bool empty() const { return data_.empty(); }
  size_t pixel_count() const { return static_cast<size_t>(width_) * height_; }

  float* pixel(int x, int y) {
    assert(x >= 0 && x < width_ && y >= 0 && y < height_);
    return data_.data() + (static_cast<size_t>(y) * width_ + x) * channels_;
  }
  const float* pixel(int x, int y) const {
    assert(x >= 0 && x < width_ && y >= 0 && y < height_);
    return data_.data() + (static_cast<size_t>(y) * width_ + x) * channels_;
  }
  float& at(int x, int y, int c) { return pixel(x, y)[c]; }
  float at(int x, int y, int c) const { return pixel(x, y)[c]; }

  std::vector<float>& data() { return data_; }
  const std::vector<float>& data() const { return data_; }

  bool same_shape(const Image& o) const {
    return width_ == o.width_ && height_ == o.height_ && channels_ == o.channels_;
  }

 private:
  int width_ = 0, height_ = 0, channels_ = 0;
  std::vector<float> data_;
};

}  // namespace dofcache::image
