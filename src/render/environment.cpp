#include "dofcache/render/environment.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include "dofcache/core/content_hash.h"
#include "dofcache/core/error.h"
#include "dofcache/image/image_io.h"

namespace dofcache::render {
namespace {

constexpr float kPi = 3.14159265358979f;
constexpr std::uint64_t kEnvironmentHashSeed = 0x656e7669726f6e6dULL;  // "environm"

// Normalised running sums of `w` (the last exactly 1); uniform if they sum to 0, so that a
// black row still maps u to a column (its marginal probability is 0 anyway).
void cumulative(const double* w, std::size_t n, float* out) {
  double total = 0.0;
  for (std::size_t i = 0; i < n; ++i) total += w[i];
  double run = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    run += total > 0.0 ? w[i] : 1.0;
    out[i] = static_cast<float>(run / (total > 0.0 ? total : static_cast<double>(n)));
  }
  out[n - 1] = 1.0f;
}

// Index of the interval of a CDF that u in [0, 1) falls in (never an empty one: its upper end
// exceeds u), and u's position within it.
std::size_t pick(const float* cdf, std::size_t n, float u, float* remainder) {
  const float* it = std::min(std::upper_bound(cdf, cdf + n, u), cdf + n - 1);
  const float lo = it > cdf ? it[-1] : 0.0f;
  const float width = *it - lo;
  *remainder = width > 0.0f ? std::clamp((u - lo) / width, 0.0f, 0x1.fffffep-1f) : 0.5f;
  return static_cast<std::size_t>(it - cdf);
}

glm::vec3 uniform_sphere(glm::vec2 u) {
  const float z = 1.0f - 2.0f * u.x;
  const float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
  const float phi = 2.0f * kPi * u.y;
  return {r * std::cos(phi), z, r * std::sin(phi)};
}

}  // namespace

Environment Environment::constant(glm::vec3 radiance, bool visible) {
  Environment e;
  e.constant_ = radiance;
  e.visible_ = visible;
  e.total_ = static_cast<double>(scene::luminance(radiance));
  e.mean_ = radiance;
  ContentHasher h(kEnvironmentHashSeed);
  h.add(std::string("constant"));
  for (int c = 0; c < 3; ++c) h.add_float32(radiance[c]);
  e.hash_ = h.value();
  return e;
}

Environment Environment::lat_long(const image::Image& map, float strength, float rotation,
                                  bool visible) {
  if (map.channels() < 3 || map.height() < 1 || map.width() != 2 * map.height())
    throw Error("environment map must be a 2:1 lat-long RGB image, got " +
                std::to_string(map.width()) + "x" + std::to_string(map.height()));
  Environment e;
  e.width_ = map.width();
  e.height_ = map.height();
  e.visible_ = visible;
  e.rotation_ = rotation;
  e.cos_rot_ = std::cos(rotation);
  e.sin_rot_ = std::sin(rotation);
  e.texels_.resize(map.pixel_count());
  ContentHasher h(kEnvironmentHashSeed);
  h.add(e.width_), h.add(e.height_), h.add_float32(rotation);
  for (int y = 0; y < e.height_; ++y)
    for (int x = 0; x < e.width_; ++x) {
      const float* p = map.pixel(x, y);
      glm::vec3 c(p[0], p[1], p[2]);
      if (!std::isfinite(c.x) || !std::isfinite(c.y) || !std::isfinite(c.z) || c.x < 0.0f ||
          c.y < 0.0f || c.z < 0.0f)
        throw Error("environment map texel (" + std::to_string(x) + ", " + std::to_string(y) +
                    ") is not a finite non-negative colour");
      c *= strength;
      e.texels_[static_cast<std::size_t>(y) * e.width_ + x] = c;
      for (int k = 0; k < 3; ++k) h.add_float32(c[k]);
    }
  e.hash_ = h.value();
  e.build_distribution();
  return e;
}

Environment Environment::default_sky(float strength, bool visible) {
  // Smooth in elevation only, so 16 rows are plenty; 32 columns keep the texels square.
  constexpr int kHeight = 16;
  image::Image map(2 * kHeight, kHeight, 3);
  const glm::vec3 zenith(0.62f, 0.76f, 1.0f), horizon(1.0f), ground(0.3f);
  for (int y = 0; y < kHeight; ++y) {
    const float elevation = 0.5f * kPi - kPi * (static_cast<float>(y) + 0.5f) / kHeight;
    const float s = std::sin(elevation);
    // Above the horizon, white fading to blue with height; below it, a grey ground that meets
    // the horizon's white over the first few degrees (no hard seam in the background).
    const glm::vec3 c = s >= 0.0f ? glm::mix(horizon, zenith, std::sqrt(s))
                                  : glm::mix(horizon, ground, std::min(1.0f, -s * 6.0f));
    for (int x = 0; x < 2 * kHeight; ++x)
      for (int k = 0; k < 3; ++k) map.at(x, y, k) = c[k];
  }
  return lat_long(map, strength, 0.0f, visible);
}

void Environment::build_distribution() {
  const auto w = static_cast<std::size_t>(width_), hgt = static_cast<std::size_t>(height_);
  std::vector<double> weight(w * hgt), row(hgt);
  glm::dvec3 mean(0.0);
  double solid_angle = 0.0;
  for (std::size_t y = 0; y < hgt; ++y) {
    // sin(theta) at the row's centre: the solid angle a texel of that row covers, up to a factor.
    const double sin_theta = std::sin(kPi * (static_cast<double>(y) + 0.5) / height_);
    for (std::size_t x = 0; x < w; ++x) {
      const glm::vec3 c = texels_[y * w + x];
      weight[y * w + x] = static_cast<double>(scene::luminance(c)) * sin_theta;
      row[y] += weight[y * w + x];
      mean += glm::dvec3(c) * sin_theta;
      solid_angle += sin_theta;
    }
    total_ += row[y];
  }
  mean_ = glm::vec3(mean / solid_angle);
  marginal_.resize(hgt);
  conditional_.resize(w * hgt);
  texel_pdf_.assign(w * hgt, 0.0f);
  if (!(total_ > 0.0)) return;
  cumulative(row.data(), hgt, marginal_.data());
  for (std::size_t y = 0; y < hgt; ++y) cumulative(&weight[y * w], w, &conditional_[y * w]);
  // pdf_uv of a texel: its probability weight/total over its area 1/(W H) in the unit square.
  const double scale = static_cast<double>(w * hgt) / total_;
  for (std::size_t i = 0; i < w * hgt; ++i) texel_pdf_[i] = static_cast<float>(weight[i] * scale);
}

glm::vec3 Environment::to_local(glm::vec3 d) const {  // the inverse rotation
  return {cos_rot_ * d.x - sin_rot_ * d.z, d.y, sin_rot_ * d.x + cos_rot_ * d.z};
}

glm::vec3 Environment::to_world(glm::vec3 d) const {  // right-handed about +Y
  return {cos_rot_ * d.x + sin_rot_ * d.z, d.y, -sin_rot_ * d.x + cos_rot_ * d.z};
}

glm::ivec2 Environment::texel_of(glm::vec3 d) const {
  // theta from +Y; phi = 0 towards -Z, +pi/2 towards +X; u = 0.5 at phi = 0.
  // atan2 rather than acos: accurate near the poles, where acos(y) rounds to 0.
  const float theta = std::atan2(std::sqrt(d.x * d.x + d.z * d.z), d.y);
  const float phi = std::atan2(d.x, -d.z);
  const float u = 0.5f + phi / (2.0f * kPi), v = theta / kPi;
  return {std::clamp(static_cast<int>(u * width_), 0, width_ - 1),
          std::clamp(static_cast<int>(v * height_), 0, height_ - 1)};
}

glm::vec3 Environment::radiance(glm::vec3 wi) const {
  if (is_constant()) return constant_;
  const glm::ivec2 t = texel_of(to_local(wi));
  return texels_[static_cast<std::size_t>(t.y) * width_ + t.x];
}

bool Environment::sample(glm::vec2 u, glm::vec3* wi, float* pdf, glm::vec3* radiance) const {
  if (is_black()) return false;
  if (is_constant()) {
    *wi = uniform_sphere(u);
    *pdf = 1.0f / (4.0f * kPi);
    *radiance = constant_;
    return true;
  }
  float dv, du;
  const std::size_t y = pick(marginal_.data(), marginal_.size(), u.y, &dv);
  const std::size_t x =
      pick(&conditional_[y * width_], static_cast<std::size_t>(width_), u.x, &du);
  const float mu = (static_cast<float>(x) + du) / width_;
  // Off the poles, where sin(theta) = 0 and the density is undefined (a set of measure zero).
  const float mv = std::clamp((static_cast<float>(y) + dv) / height_, 1e-6f, 1.0f - 1e-6f);
  const float theta = kPi * mv, phi = 2.0f * kPi * (mu - 0.5f);
  const float sin_theta = std::sin(theta);
  if (!(sin_theta > 0.0f)) return false;
  const glm::vec3 local(sin_theta * std::sin(phi), std::cos(theta), -sin_theta * std::cos(phi));
  *wi = to_world(local);
  // Evaluated through pdf() so that the two agree exactly, as MIS needs.
  *pdf = this->pdf(*wi);
  *radiance = this->radiance(*wi);
  return *pdf > 0.0f && std::isfinite(*pdf);
}

float Environment::pdf(glm::vec3 wi) const {
  if (is_black()) return 0.0f;
  if (is_constant()) return 1.0f / (4.0f * kPi);
  const glm::vec3 d = to_local(wi);
  const float sin_theta = std::sqrt(d.x * d.x + d.z * d.z);  // accurate near the poles
  if (!(sin_theta > 0.0f)) return 0.0f;
  const glm::ivec2 t = texel_of(d);
  return texel_pdf_[static_cast<std::size_t>(t.y) * width_ + t.x] /
         (2.0f * kPi * kPi * sin_theta);
}

Environment load_environment(const std::string& path, float strength, float rotation_degrees,
                             bool visible, std::uint64_t max_pixels,
                             std::vector<std::string>* warnings) {
  // An RGBA file of max_pixels texels is within the read's budget; the texel count is checked
  // again below, for files with fewer channels.
  const std::string where = "environment map '" + path + "'";
  image::Image map;
  try {
    map = image::read_image(path, max_pixels * 4);
  } catch (const Error& e) {
    const std::string what = e.what();
    if (what.find("image size limit") == std::string::npos) throw;
    throw Error(what + "; " + where + " may have " + std::to_string(max_pixels) +
                " texels (--max-texture-pixels)");
  }
  if (map.pixel_count() > max_pixels)
    throw Error(where + " has " + std::to_string(map.pixel_count()) +
                " texels, more than the limit of " + std::to_string(max_pixels) +
                " (--max-texture-pixels)");
  if (map.width() != 2 * map.height())
    throw Error(where + " is " + std::to_string(map.width()) + "x" +
                std::to_string(map.height()) + ", not a 2:1 lat-long map");
  std::size_t negative = 0;
  for (std::size_t i = 0; i < map.data().size(); ++i) {
    float& v = map.data()[i];
    if (!std::isfinite(v)) {
      const std::size_t p = i / 3;
      throw Error(where + " has a NaN or infinite texel at (" +
                  std::to_string(p % map.width()) + ", " + std::to_string(p / map.width()) + ")");
    }
    if (v < 0.0f) v = 0.0f, ++negative;
  }
  if (negative > 0 && warnings)
    warnings->push_back(where + ": " + std::to_string(negative) +
                        " negative values clamped to 0");
  return Environment::lat_long(map, strength, rotation_degrees * (kPi / 180.0f), visible);
}

void EnvironmentSettings::validate() const {
  if (!(strength >= 0.0f && strength <= 1e6f))
    throw Error("environment strength must be in [0, 1e6]");
  if (!(std::abs(rotation_degrees) <= 1e6f))
    throw Error("environment rotation must be a finite angle in degrees");
  if (!path.empty() && color)
    throw Error("--env and --env-color are exclusive: one environment at a time");
  if (color && !(color->x >= 0.0f && color->y >= 0.0f && color->z >= 0.0f &&
                 std::isfinite(color->x) && std::isfinite(color->y) && std::isfinite(color->z)))
    throw Error("environment colour must be three finite non-negative numbers");
}

namespace {
std::string describe(const Environment& e, const std::string& what) {
  const glm::vec3 m = e.mean_radiance();
  char buf[200];
  std::snprintf(buf, sizeof buf, "%s, mean radiance (%.3g, %.3g, %.3g)%s", what.c_str(), m.x, m.y,
                m.z, e.visible() ? "" : ", not visible");
  return buf;
}
}  // namespace

ResolvedEnvironment resolve_environment(const EnvironmentSettings& s, const scene::Scene& scene,
                                        const scene::LoadLimits& limits) {
  s.validate();
  ResolvedEnvironment r;
  std::shared_ptr<Environment> e;
  std::string what;
  if (!s.path.empty()) {
    e = std::make_shared<Environment>(load_environment(
        s.path, s.strength, s.rotation_degrees, s.visible, limits.max_texture_pixels,
        &r.warnings));
    what = "map " + s.path + " (" + std::to_string(e->width()) + "x" +
           std::to_string(e->height()) + ")";
  } else if (s.color) {
    e = std::make_shared<Environment>(Environment::constant(*s.color * s.strength, s.visible));
    what = "constant colour";
  } else if (s.default_sky && scene.emitters.empty() && scene.lights.empty()) {
    e = std::make_shared<Environment>(Environment::default_sky(s.strength, s.visible));
    what = "default sky";
    r.default_sky = true;
  }
  if (!e || e->is_black()) {
    r.description = "none";
    r.default_sky = false;
    return r;
  }
  r.description = describe(*e, what);
  r.environment = std::move(e);
  return r;
}

}  // namespace dofcache::render
