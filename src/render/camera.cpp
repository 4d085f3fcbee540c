#include "dofcache/render/camera.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <glm/geometric.hpp>

namespace dofcache::render {

ThinLensCamera::ThinLensCamera(const glm::mat4& camera_to_world, float yfov,
                               const lens::ThinLens& lens, int width, int height,
                               const lens::MountedLens& mounted)
    : imaging_{lens, yfov, height}, aperture_(lens.aperture), width_(width), height_(height),
      mounted_(mounted) {
  position_ = glm::vec3(camera_to_world[3]);
  right_ = glm::normalize(glm::vec3(camera_to_world[0]));
  up_ = glm::normalize(glm::vec3(camera_to_world[1]));
  forward_ = -glm::normalize(glm::vec3(camera_to_world[2]));  // glTF cameras look down -Z
  if (mounted_) {
    // The thin-lens equivalent sits at the front principal plane, in front of the sensor.
    yfov = static_cast<float>(mounted_.yfov());
    imaging_.yfov = yfov;
    position_ += forward_ * static_cast<float>(mounted_.principal_offset());
  }
  tan_half_y_ = std::tan(0.5f * yfov);
  tan_half_x_ = tan_half_y_ * static_cast<float>(width) / static_cast<float>(height);
  const lens::ApertureShape& a = lens.aperture;
  shift_ = glm::vec2(static_cast<float>(2.0 * a.shift_x), static_cast<float>(2.0 * a.shift_y)) *
           tan_half_y_;
  tilted_ = a.tilted();
  tilt_sin_ = glm::dvec2(std::sin(a.tilt_x_deg * M_PI / 180.0), std::sin(a.tilt_y_deg * M_PI / 180.0));
}

glm::vec2 ThinLensCamera::film_slopes(glm::vec2 film) const {
  // Shift moves the film window by shift image heights (2 tan(yfov / 2) in slope).
  return {(2.0f * film.x / static_cast<float>(width_) - 1.0f) * tan_half_x_ + shift_.x,
          (1.0f - 2.0f * film.y / static_cast<float>(height_)) * tan_half_y_ + shift_.y};
}

glm::vec3 ThinLensCamera::direction_of(glm::vec2 slopes) const {
  return forward_ + slopes.x * right_ + slopes.y * up_;
}

glm::vec3 ThinLensCamera::direction_to_film(glm::vec2 film) const {
  return direction_of(film_slopes(film));
}

glm::mat4 ThinLensCamera::film_to_world() const {
  // direction_to_film is affine in (x, y): forward + sx right + sy up with sx, sy as there.
  const float ax = 2.0f * tan_half_x_ / static_cast<float>(width_);
  const float ay = 2.0f * tan_half_y_ / static_cast<float>(height_);
  return glm::mat4(glm::vec4(ax * right_, 0.0f), glm::vec4(-ay * up_, 0.0f),
                   glm::vec4(forward_ + (shift_.x - tan_half_x_) * right_ +
                                 (shift_.y + tan_half_y_) * up_, 0.0f),
                   glm::vec4(position_, 1.0f));
}

scene::Ray ThinLensCamera::pinhole_ray(glm::vec2 film) const {
  scene::Ray ray;
  ray.origin = position_;
  ray.direction = glm::normalize(direction_to_film(film));
  ray.cull_back_faces = true;  // glTF: single-sided surfaces are invisible from behind
  return ray;
}

glm::dvec2 ThinLensCamera::lens_film(glm::vec2 film) const {
  // The lens turns the image over: the scene's right and up land on the film's -x and -y.
  return {(0.5 - film.x / width_) * mounted_.film_size.x,
          (film.y / height_ - 0.5) * mounted_.film_size.y};
}

LensSample ThinLensCamera::placed(const lens::RealLens::Sample& s) const {
  LensSample out;
  out.weight = static_cast<float>(s.weight);
  const glm::dvec3 o = s.ray.origin, d = s.ray.direction;
  const float z = static_cast<float>(o.z - mounted_.principal_offset());
  out.ray.origin = position_ + static_cast<float>(o.x) * right_ + static_cast<float>(o.y) * up_ +
                   z * forward_;
  out.ray.direction = glm::normalize(static_cast<float>(d.x) * right_ +
                                     static_cast<float>(d.y) * up_ +
                                     static_cast<float>(d.z) * forward_);
  out.ray.cull_back_faces = true;
  return out;
}

void ThinLensCamera::lens_rays(std::size_t n, const glm::vec2* film, const glm::vec2* lens_u,
                               const int* band, LensSample* out) const {
  if (!mounted_) {
    for (std::size_t i = 0; i < n; ++i) out[i] = lens_ray(film[i], lens_u[i], band[i]);
    return;
  }
  // In blocks, so that the lens's inputs and outputs stay on the stack.
  constexpr std::size_t kBlock = 16;
  glm::dvec2 f[kBlock], u[kBlock];
  lens::RealLens::Sample s[kBlock];
  for (std::size_t i0 = 0; i0 < n; i0 += kBlock) {
    const std::size_t m = std::min(kBlock, n - i0);
    for (std::size_t i = 0; i < m; ++i) f[i] = lens_film(film[i0 + i]), u[i] = lens_u[i0 + i];
    mounted_.lens->sample_n(m, f, u, band + i0, s);
    for (std::size_t i = 0; i < m; ++i) out[i0 + i] = placed(s[i]);
  }
}

LensSample ThinLensCamera::lens_ray(glm::vec2 film, glm::vec2 lens_u, int band) const {
  if (mounted_) return placed(mounted_.lens->sample(lens_film(film), glm::dvec2(lens_u), band));
  // The pinhole direction has depth component 1, so it reaches the focal plane at parameter P.
  glm::vec2 slopes = film_slopes(film);
  const BandOptics optics = band_optics(band);
  float p = static_cast<float>(optics.focus_distance);
  if (band >= 0) slopes /= static_cast<float>(optics.magnification);
  if (tilted_) p = static_cast<float>(focus_depth(slopes, p));
  glm::vec3 focus_point = position_ + direction_of(slopes) * p;
  const lens::ApertureShape& shape = imaging_.lens.aperture;
  float rho = 0.0f;  // asked for only where a profile weighs it (a square root saved per ray)
  glm::vec2 disk = aperture_.sample(lens_u, shape.weighted() ? &rho : nullptr) *
                   static_cast<float>(imaging_.lens.aperture_radius());
  LensSample out;
  if (shape.weighted()) out.weight = static_cast<float>(shape.transmission(rho));
  if (shape.vignetting()) {
    // The ray from the lens point `disk` to the focus point (offset slopes * P, depth P) crosses
    // the stop's plane, depth D, at disk (1 - D / P) + slopes D.
    const float d = static_cast<float>(shape.stop.distance), r = static_cast<float>(shape.stop.radius);
    const glm::vec2 at_stop = disk * (1.0f - d / p) + slopes * d;
    if (glm::dot(at_stop, at_stop) > r * r) out.weight = 0.0f;
  }
  scene::Ray& ray = out.ray;
  ray.origin = position_ + disk.x * right_ + disk.y * up_;
  ray.direction = glm::normalize(focus_point - ray.origin);
  ray.cull_back_faces = true;  // glTF: single-sided surfaces are invisible from behind
  return out;
}

BokehSpot ThinLensCamera::bokeh(glm::vec2 film, double depth, int band) const {
  // The lens ray from lens point l towards the focus point (slopes s_b, depth p) is at
  // l (1 - D / p) + s_b D at depth D; it meets the point (slopes s0, depth D) from film slopes
  // s_b = s0 + l (1 / p - 1 / D), which the band's magnification m scales (lens_ray divides by
  // it). Tilted, 1 / p = 1 / p0 - (s_b - s0) . t (focus_depth; p0 the centre's, t = (sin tilt_y,
  // sin tilt_x) / F), so s_b - s0 = l g / (1 + l . t) with g = 1 / p0 - 1 / D.
  const lens::ApertureShape& a = imaging_.lens.aperture;
  const glm::vec2 s0 = film_slopes(film);
  const BandOptics optics = band_optics(band);
  double p = optics.focus_distance;
  const double m = optics.magnification;
  if (tilted_) p = focus_depth(s0, p);
  const double slope_per_pixel = 2.0 * tan_half_y_ / height_;
  BokehSpot out;
  const glm::vec2 sm = s0 * static_cast<float>(m) - shift_;
  out.centre = {(sm.x / tan_half_x_ + 1.0f) * 0.5f * static_cast<float>(width_),
                (1.0f - sm.y / tan_half_y_) * 0.5f * static_cast<float>(height_)};
  const double r = imaging_.lens.aperture_radius();
  out.scale = static_cast<float>(m * r * (depth - p) / (p * depth) / slope_per_pixel);
  if (tilted_)
    out.tilt = glm::vec2(static_cast<float>(r * tilt_sin_.y / imaging_.lens.focal_length),
                         static_cast<float>(r * tilt_sin_.x / imaging_.lens.focal_length));
  lens::ThinLens::StopCircle circles[2];
  imaging_.lens.stop_circles(glm::dvec2(s0), depth, circles);
  for (int i = 0; i < 2; ++i)
    if (std::isfinite(circles[i].radius))
      out.stops[i] = {glm::vec2(circles[i].centre), static_cast<float>(circles[i].radius)};
  out.normalised = a.rims.normalised;
  return out;
}

ThinLensCamera::BandOptics ThinLensCamera::band_optics(int band) const {
  if (band < 0) return {imaging_.lens.focus_distance, 1.0};
  const lens::ApertureShape& a = imaging_.lens.aperture;
  const double t = lens::ApertureShape::band_position(band);
  return {imaging_.lens.focus_distance + a.axial_ca * t, 1.0 + a.lateral_ca * t};
}

double ThinLensCamera::focus_depth(glm::vec2 slopes, double p) const {
  // The tilted plane z / P - y sin(tilt_x) / F - x sin(tilt_y) / F = 1 (lens/aperture.h) met
  // by the pinhole direction (slopes, 1). Where it is met far away or behind, the lens rays are
  // as good as parallel: 10^4 P.
  const double inv = 1.0 / p - (slopes.y * tilt_sin_.x + slopes.x * tilt_sin_.y) /
                                   imaging_.lens.focal_length;
  return inv > 1e-4 / p ? 1.0 / inv : 1e4 * p;
}

lens::LensImaging ThinLensCamera::imaging_at(glm::vec3 world) const {
  if (!tilted_) return imaging_;
  const glm::vec3 v = world - position_;
  const float z = glm::dot(v, forward_);
  if (!(z > 0.0f)) return imaging_;
  const glm::vec2 slopes(glm::dot(v, right_) / z, glm::dot(v, up_) / z);
  lens::LensImaging at = imaging_;
  // Beyond the focal length, so that the thin-lens formulas hold.
  at.lens.focus_distance = std::max(focus_depth(slopes, imaging_.lens.focus_distance),
                                    1.001 * imaging_.lens.focal_length);
  return at;
}

float ThinLensCamera::t_at_depth(const scene::Ray& ray, float z) const {
  float along = glm::dot(ray.direction, forward_);
  if (along <= 0.0f) return 0.0f;
  float t = (z - glm::dot(ray.origin - position_, forward_)) / along;
  return t > 0.0f ? t : 0.0f;
}

}  // namespace dofcache::render
