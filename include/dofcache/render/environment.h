#pragma once
// Light from infinitely far away: a lat-long (equirectangular) radiance map, a constant colour, or
// the default sky given to scenes without any light.
//
// Directions are world directions, glTF's +Y up. A lat-long map of W x H = 2H x H texels has its
// top row at the zenith (+Y) and the centre of each row towards -Z (what a default glTF camera
// looks at), +X a quarter turn to the right: seen from inside, the map is not mirrored. The map is
// turned by `rotation` about +Y (right-handed: a positive angle takes +X towards -Z).
//
// Importance sampling as pbrt-v4's ImageInfiniteLight: a piecewise-constant 2-D distribution over
// the texels, weight = luminance x sin(theta) of the texel's row (a texel near a pole covers less
// solid angle), sampled by a marginal CDF over rows and a conditional CDF over the columns of the
// chosen row. A point (u, v) of the map has solid angle dw = 2 pi^2 sin(theta) du dv, so
//   pdf_w(wi) = pdf_uv(u, v) / (2 pi^2 sin(theta)).
// The radiance is the texel's (nearest, no filtering), so it is exactly proportional to the
// sampled density inside each row's band and every direction with radiance has a positive pdf.
// A constant environment is sampled uniformly over the sphere (pdf 1/(4 pi)).
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "dofcache/image/image.h"
#include "dofcache/scene/gltf_loader.h"
#include "dofcache/scene/scene.h"

namespace dofcache::render {

class Environment {
 public:
  // A uniform environment of radiance `radiance` (linear RGB).
  static Environment constant(glm::vec3 radiance, bool visible = true);
  // A lat-long map (2:1, RGB, finite and non-negative texels) times `strength`, turned by
  // `rotation` radians about +Y. Throws dofcache::Error (one line) for other maps.
  static Environment lat_long(const image::Image& map, float strength, float rotation,
                              bool visible = true);
  // The sky of scenes without lights: white at the horizon, a pale blue at the zenith (luminance
  // 0.74), a grey ground (0.3), smooth; mean luminance 0.59, about as bright as a glTF viewer's
  // neutral lighting.
  static Environment default_sky(float strength = 1.0f, bool visible = true);

  // Radiance arriving from direction `wi` (unit, pointing away from the receiver).
  glm::vec3 radiance(glm::vec3 wi) const;
  // A direction drawn with the density pdf(wi) from u in [0, 1)^2; false if the map is black.
  bool sample(glm::vec2 u, glm::vec3* wi, float* pdf, glm::vec3* radiance) const;
  // The solid-angle density with which sample() draws `wi`.
  float pdf(glm::vec3 wi) const;

  bool visible() const { return visible_; }  // seen by camera rays that miss the scene
  bool is_constant() const { return texels_.empty(); }
  bool is_black() const { return !(total_ > 0.0); }
  int width() const { return width_; }
  int height() const { return height_; }
  float rotation() const { return rotation_; }
  // Mean radiance over the sphere (solid-angle weighted), for messages and statistics.
  glm::vec3 mean_radiance() const { return mean_; }
  // Hash of everything that changes the light (not visibility): part of a sequence's identity.
  std::uint64_t content_hash() const { return hash_; }

 private:
  // Texel (column, row) a local (unrotated) direction falls in, and the local direction of map
  // point (u, v).
  glm::ivec2 texel_of(glm::vec3 local) const;
  glm::vec3 to_local(glm::vec3 world) const;
  glm::vec3 to_world(glm::vec3 local) const;
  void build_distribution();

  int width_ = 0, height_ = 0;
  std::vector<glm::vec3> texels_;  // row-major from the top (zenith) row; empty: constant
  glm::vec3 constant_{0.0f};
  float rotation_ = 0.0f, cos_rot_ = 1.0f, sin_rot_ = 0.0f;
  bool visible_ = true;
  double total_ = 0.0;         // sum of the texel weights (luminance x sin(theta))
  std::vector<float> marginal_;     // cumulative over rows, normalised
  std::vector<float> conditional_;  // per row, cumulative over its columns, normalised
  std::vector<float> texel_pdf_;    // pdf_uv of each texel (= weight x W x H / total)
  glm::vec3 mean_{0.0f};
  std::uint64_t hash_ = 0;
};

// Reads a lat-long map (.exr, .hdr, or anything OpenImageIO reads as float RGB) for
// Environment::lat_long. Refused in one line: a missing or unreadable file, an aspect other than
// 2:1, more than `max_pixels` texels, a NaN or infinite texel. Negative texels (the ringing of a
// resampling filter) are clamped to 0; `warnings`, if given, receives a note with their count.
Environment load_environment(const std::string& path, float strength, float rotation_degrees,
                             bool visible, std::uint64_t max_pixels,
                             std::vector<std::string>* warnings = nullptr);

// The environment options of the render and sequence commands.
struct EnvironmentSettings {
  std::string path;                 // --env: a lat-long map; empty for none
  std::optional<glm::vec3> color;   // --env-color: a constant environment
  float strength = 1.0f;            // --env-strength
  float rotation_degrees = 0.0f;    // --env-rotation, about +Y
  bool visible = true;              // --env-visible: the background of camera rays that miss
  bool default_sky = true;          // the default sky for scenes with no light of any kind

  void validate() const;  // throws dofcache::Error on absurd values
};

struct ResolvedEnvironment {
  std::shared_ptr<const Environment> environment;  // null: no environment light
  bool default_sky = false;  // the scene had no light and got the default sky
  std::string description;   // for messages and statistics ("none" without one)
  std::vector<std::string> warnings;
};

// The environment a render uses: the map of `path`, else the constant colour, else the default
// sky if the scene has no emissive triangle, no punctual light and the default sky is allowed.
// An environment that is black everywhere (e.g. --env-color 0,0,0) is none. The map is limited to
// `limits.max_texture_pixels` texels.
ResolvedEnvironment resolve_environment(const EnvironmentSettings& settings,
                                        const scene::Scene& scene,
                                        const scene::LoadLimits& limits);

}  // namespace dofcache::render
