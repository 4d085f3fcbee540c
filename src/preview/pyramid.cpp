#include "dofcache/preview/pyramid.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "dofcache/core/error.h"
#include "kernels.h"

namespace dofcache::preview {

double pyramid_level_variance(int level) {
  // Reduce k -> k+1 adds the variance of a 4-tap box at level k: 1.25 * 4^k; expand k -> k-1
  // adds the quadratic B-spline's 1/4 of a level-k pixel: 0.25 * 4^k. Summed:
  // 1.25 (4^l - 1) / 3 + (4^l - 1) / 3 = 0.75 (4^l - 1).
  return 0.75 * (std::ldexp(1.0, 2 * level) - 1.0);
}

int pyramid_max_level(int width, int height) {
  int l = 0;
  for (int w = width, h = height; w > 1 || h > 1; w = (w + 1) / 2, h = (h + 1) / 2) ++l;
  return l;
}

LevelBlend level_blend_for_radius(double radius, int max_level, bool blend) {
  LevelBlend b;
  if (!(radius > 0.5) || max_level <= 0) return b;
  const double target = 0.25 * radius * radius;  // variance of a disk of this radius, per axis
  if (!blend) {
    int l = 1;
    while (l < max_level && pyramid_level_variance(l) < target) ++l;
    b.level = l;
    return b;
  }
  int l = 0;
  while (l + 1 < max_level && pyramid_level_variance(l + 1) <= target) ++l;
  double v0 = pyramid_level_variance(l), v1 = pyramid_level_variance(l + 1);
  b.level = l;
  b.t = static_cast<float>(std::clamp((target - v0) / (v1 - v0), 0.0, 1.0));
  if (b.t >= 1.0f) {  // only at the top level: use it alone
    b.level = l + 1;
    b.t = 0;
  }
  return b;
}

std::vector<float> disk_profile_taps(double radius) {
  if (!(radius > 0.5)) return {1.0f};
  const double r = radius;
  // Integral of sqrt(r^2 - t^2) from -r to x, over the half disk's area pi r^2 / 2.
  auto cdf = [r](double x) {
    x = std::clamp(x, -r, r);
    return (x * std::sqrt(r * r - x * x) + r * r * std::asin(x / r)) / (M_PI * r * r) + 0.5;
  };
  const int R = static_cast<int>(std::ceil(r - 0.5));
  std::vector<double> w(2 * R + 1);
  double sum = 0;
  for (int k = -R; k <= R; ++k) sum += w[k + R] = cdf(k + 0.5) - cdf(k - 0.5);
  std::vector<float> taps(w.size());  // exactly symmetric (the blur sums the pairs at +-k first)
  for (int k = 0; k <= 2 * R; ++k) taps[k] = static_cast<float>((w[k] + w[2 * R - k]) / (2 * sum));
  return taps;
}

image::Image disk_profile_blur(const image::Image& image, double radius) {
  const std::vector<float> taps = disk_profile_taps(radius);
  const int R = static_cast<int>(taps.size() / 2), w = image.width(), h = image.height(),
            nc = image.channels();
  image::Image tmp(w, h, nc, 0.0f), out(w, h, nc, 0.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < nc; ++c) {
        float s = 0;
        for (int k = -R; k <= R; ++k)
          s += taps[k + R] * image.at(std::clamp(x + k, 0, w - 1), y, c);
        tmp.at(x, y, c) = s;
      }
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < nc; ++c) {
        float s = 0;
        for (int k = -R; k <= R; ++k) s += taps[k + R] * tmp.at(x, std::clamp(y + k, 0, h - 1), c);
        out.at(x, y, c) = s;
      }
  return out;
}

namespace {

std::vector<detail::Rgba> to_rgba(const image::Image& img) {
  std::vector<detail::Rgba> out(img.pixel_count(), detail::Rgba{0, 0, 0, 0});
  const int c = img.channels();
  const float* p = img.data().data();
  for (size_t i = 0; i < out.size(); ++i) {
    float* o = &out[i].r;
    for (int k = 0; k < c; ++k) o[k] = p[i * c + k];
  }
  return out;
}

void from_rgba(const std::vector<detail::Rgba>& px, image::Image& img) {
  const int c = img.channels();
  float* p = img.data().data();
  for (size_t i = 0; i < img.pixel_count(); ++i) {
    const float* o = &px[i].r;
    for (int k = 0; k < c; ++k) p[i * c + k] = o[k];
  }
}

void check_channels(const image::Image& img, const char* what) {
  if (img.channels() < 1 || img.channels() > 4)
    throw Error(std::string(what) + ": 1 to 4 channels supported");
}

}  // namespace

void pyramid_reduce(const image::Image& fine, image::Image& coarse) {
  check_channels(fine, "pyramid_reduce");
  const int cw = (fine.width() + 1) / 2, ch = (fine.height() + 1) / 2;
  std::vector<detail::Rgba> src = to_rgba(fine), dst(static_cast<size_t>(cw) * ch);
  detail::ScratchRows scratch;
  detail::reduce_box4({src.data(), fine.width(), fine.height(), fine.width()},
                      {dst.data(), cw, ch, cw}, scratch);
  coarse = image::Image(cw, ch, fine.channels());
  from_rgba(dst, coarse);
}

void pyramid_expand(const image::Image& coarse, int fine_width, int fine_height,
                    image::Image& fine) {
  check_channels(coarse, "pyramid_expand");
  if ((fine_width + 1) / 2 != coarse.width() || (fine_height + 1) / 2 != coarse.height())
    throw Error("pyramid_expand: the fine size does not reduce to the coarse size");
  std::vector<detail::Rgba> src = to_rgba(coarse),
                            dst(static_cast<size_t>(fine_width) * fine_height);
  detail::ScratchRows scratch;
  detail::expand_bspline2({src.data(), coarse.width(), coarse.height(), coarse.width()}, fine_width,
                          fine_height, scratch,
                          [&](int y, const detail::Rgba* row, const detail::Runs&) {
                            std::copy(row, row + fine_width,
                                      dst.data() + static_cast<size_t>(y) * fine_width);
                          });
  fine = image::Image(fine_width, fine_height, coarse.channels());
  from_rgba(dst, fine);
}

image::Image pyramid_blur(const image::Image& image, double radius, bool blend_levels) {
  check_channels(image, "pyramid_blur");
  LevelBlend b = level_blend_for_radius(radius, pyramid_max_level(image.width(), image.height()),
                                        blend_levels);
  const int top = b.t > 0 ? b.level + 1 : b.level;
  if (top == 0) return image;
  std::vector<image::Image> levels(top + 1);
  levels[0] = image;
  for (int l = 0; l < top; ++l) pyramid_reduce(levels[l], levels[l + 1]);
  image::Image mix = levels[b.level];
  if (b.t > 0) {
    image::Image up;
    pyramid_expand(levels[b.level + 1], mix.width(), mix.height(), up);
    for (size_t i = 0; i < mix.data().size(); ++i)
      mix.data()[i] = (1 - b.t) * mix.data()[i] + b.t * up.data()[i];
  }
  for (int l = b.level; l > 0; --l) {
    image::Image up;
    pyramid_expand(mix, levels[l - 1].width(), levels[l - 1].height(), up);
    mix = std::move(up);
  }
  return mix;
}

}  // namespace dofcache::preview
