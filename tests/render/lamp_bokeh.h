#pragma once
// A small lamp's bokeh: its scene, and the area moments of one channel of its image, for tests
// that compare a bokeh with the aperture's geometry or one renderer's bokeh with another's.
#include <cmath>
#include <complex>
#include <cstdlib>
#include <string>

#include "dofcache/image/image.h"
#include "dofcache/image/image_io.h"
#include "dofcache/render/renderer.h"
#include "test_scenes.h"

namespace dofcache::testing {

// A square lamp (side `side` metres, centred at `lamp`, facing the camera) in the dark, seen by a
// camera at the origin looking down -z. With `backdrop`, a black wall just behind the lamp fills
// the view: a preview's pinhole depth is then the lamp's at its antialiased edge pixels too.
inline scene::Scene lamp_scene(glm::vec3 lamp, double side, float yfov, bool backdrop = false) {
  scene::Scene s;
  s.materials.push_back(emissive_material({1.0f, 1.0f, 1.0f}));
  const float h = static_cast<float>(side / 2);
  add_quad_z(s, lamp.x - h, lamp.x + h, lamp.y - h, lamp.y + h, lamp.z, 0, 0);
  if (backdrop) {
    s.materials.push_back(diffuse_material({0.0f, 0.0f, 0.0f}));
    const float w = -lamp.z;  // wider than the view for any yfov under 90 degrees
    add_quad_z(s, -w, w, -w, w, lamp.z * 1.001f, 1, 0);
  }
  build_emitters(s);
  s.cameras.push_back(origin_camera(yfov));
  return s;
}

// With DUMP=prefix in the environment, writes a pair of a test's images (prefixN_drt.exr and
// prefixN_preview.exr) to look at.
inline void dump_if_asked(const image::Image& drt, const image::Image& preview) {
  const char* dump = std::getenv("DUMP");
  if (!dump) return;
  static int n = 0;
  image::write_image(std::string(dump) + std::to_string(n) + "_drt.exr", drt);
  image::write_image(std::string(dump) + std::to_string(n++) + "_preview.exr", preview);
}

// An aperture image whose right half passes everything and whose left half passes a quarter
// (64 x 64, the square around the round aperture), written to `path`.
inline void write_half_aperture_image(const std::string& path) {
  image::Image half(64, 64, 3, 0.25f);
  for (int y = 0; y < 64; ++y)
    for (int x = 32; x < 64; ++x)
      for (int c = 0; c < 3; ++c) half.at(x, y, c) = 1.0f;
  image::write_image(path, half);
}

inline render::RenderSettings lamp_settings(const lens::ThinLens& lens, int size, int spp) {
  render::RenderSettings r;
  r.width = r.height = size;
  r.spp = spp;
  r.lens = lens;
  r.threads = 2;
  r.progress = Progress::Display::Never;
  return r;
}

struct BokehMoments {
  double total = 0;       // the channel's light
  double cx = 0, cy = 0;  // centroid, pixels: x right and y up from the image's centre
  // About the centroid, per unit of light (pixels^2).
  double polar = 0, xx = 0, yy = 0;
  // sum I r^2 e^{i m theta} / sum I r^2 for m = 0..16 (theta counter-clockwise from +x).
  std::complex<double> order[17] = {};
  // The lowest order from 3 up whose angular moment exceeds `threshold`: a polygon's corners.
  int corners(double threshold = 0.02) const {
    for (int k = 3; k <= 16; ++k)
      if (std::abs(order[k]) > threshold) return k;
    return 0;
  }
  // A corner's angle (degrees) from the order-n moment, modulo 360 / n.
  double corner_deg(int n) const { return std::arg(order[n]) / n * 180.0 / M_PI; }
};

inline BokehMoments bokeh_moments(const image::Image& im, int channel) {
  BokehMoments m;
  const int w = im.width(), h = im.height();
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double v = im.at(x, y, channel);
      m.total += v, m.cx += v * (x + 0.5 - w / 2.0), m.cy += v * (h / 2.0 - y - 0.5);
    }
  m.cx /= m.total, m.cy /= m.total;
  double weight = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double v = im.at(x, y, channel);
      const double dx = x + 0.5 - w / 2.0 - m.cx, dy = h / 2.0 - y - 0.5 - m.cy;
      const double r2 = dx * dx + dy * dy;
      m.xx += v * dx * dx, m.yy += v * dy * dy;
      weight += v * r2;
      for (int k = 1; k <= 16; ++k) m.order[k] += v * r2 * std::polar(1.0, k * std::atan2(dy, dx));
    }
  m.polar = weight / m.total, m.xx /= m.total, m.yy /= m.total;
  for (auto& o : m.order) o /= weight;
  return m;
}

}  // namespace dofcache::testing
