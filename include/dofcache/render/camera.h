#pragma once
// The thin-lens camera (paper section 2): pixels on a film at distance V_P behind a lens of
// aperture F/n focused at distance P. A camera ray starts at a point on the lens and passes through
// the point where the pinhole ray of its film position meets the focal plane, so every ray of one
// film point converges at depth P and points at depth D spread over the CoC of eq. (2.4).
#include <cmath>
#include <cstddef>
#include <limits>

#include <glm/mat4x4.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "dofcache/cache/frame_camera.h"
#include "dofcache/lens/real_lens.h"
#include "dofcache/lens/thin_lens.h"
#include "dofcache/scene/accel.h"
#include "dofcache/scene/scene.h"

namespace dofcache::render {

// A lens ray and its weight: the aperture's transmission profile (lens/aperture.h), 0 where the
// vignetting stop stops the ray (a lens sample that brings no light).
struct LensSample {
  scene::Ray ray;
  float weight = 1.0f;
};

// Where the lens spreads a point's light on the film (what a preview draws): the film position of
// the bokeh's centre (the point's image in a colour band), and where the lens ray through aperture
// point a (in units of the round aperture's radius, x right, y up) lands: at centre + (o.x, -o.y)
// pixels with
//     o = scale a / (1 + a . tilt)
// `scale` is the signed CoC radius: negative in front of the plane of focus, where the bokeh is
// turned by 180 degrees. `tilt` is 0 for an untilted lens; tilted, each film point focuses at its
// own depth, and the bokeh is the aperture under that projective map (exact). The vignetting
// stop lets through the rays of the aperture points inside its disc; a real lens's rims
// (lens/lens_rims.h) are two such discs.
struct StopDisc {
  glm::vec2 centre{0.0f};                                 // aperture units
  float radius = std::numeric_limits<float>::infinity();  // aperture units; +inf: none
  bool present() const { return std::isfinite(radius); }
};
struct BokehSpot {
  glm::vec2 centre{0.0f};
  float scale = 0.0f;
  glm::vec2 tilt{0.0f};  // aperture radius x (sin tilt_y, sin tilt_x) / F
  // The vignetting stop's disc, or a real lens's front and rear rims' (a point before a stop:
  // none).
  StopDisc stops[2];
  bool normalised = false;  // the image is divided by what the stops pass (LensRims)
};

class ThinLensCamera {
 public:
  // `pose` supplies position, orientation and vertical field of view; `lens` the optics.
  //
  // With a real lens mounted (lens/real_lens.h), `camera_to_world` places the sensor, lens rays
  // are traced through its elements, and `lens` must be the mounted lens's thin-lens equivalent
  // (MountedLens::equivalent): the pinhole projection, imaging() and bokeh() then are the
  // thick lens's paraxial ones, seen from its front principal plane, and `yfov` is ignored for
  // the lens's and the sensor's.
  ThinLensCamera(const glm::mat4& camera_to_world, float yfov, const lens::ThinLens& lens,
                 int width, int height, const lens::MountedLens& mounted = {});

  // `film` in pixels (x right, y down, pixel (i,j) covers [i,i+1)x[j,j+1)); `lens_u` in [0,1)^2 is
  // mapped to the aperture (lens::Aperture: the concentric mapping for a round one). Direction is
  // unit length, and its weight (the profile, the vignetting stop). `band` (0 red, 1 green, 2
  // blue; -1 none) picks the wavelength band whose focus and magnification chromatic aberration
  // shifts. A real lens's rims (lens::LensRims) shape bokeh() alone: that lens's own rays are
  // traced through it.
  LensSample lens_ray(glm::vec2 film, glm::vec2 lens_u, int band = -1) const;
  // lens_ray(film[i], lens_u[i], band[i]) for i in [0, n), each bit for bit lens_ray's: through a
  // real lens the rays are traced several at a time (RealLens::sample_n), else one by one.
  void lens_rays(std::size_t n, const glm::vec2* film, const glm::vec2* lens_u, const int* band,
                 LensSample* out) const;
  // The ray alone (its weight ignored).
  scene::Ray generate_ray(glm::vec2 film, glm::vec2 lens_u) const {
    return lens_ray(film, lens_u).ray;
  }
  scene::Ray pinhole_ray(glm::vec2 film) const;
  // The pinhole direction of a film point as slopes: camera-space (x / z, y / z), x right and y
  // up (the film's shift included).
  glm::vec2 film_slopes(glm::vec2 film) const;
  // The bokeh of the point at camera-space depth `depth` whose pinhole image is at `film` (pixels,
  // as above), in band `band` (-1: none).
  BokehSpot bokeh(glm::vec2 film, double depth, int band = -1) const;

  // (x z, y z, z, 1) -> world, for film position (x, y) in pixels at camera-space depth z: the
  // pinhole projection through the lens centre, which every lens ray of a film point's focus
  // shares (w = 0 maps (x, y, 1) to the centre ray's direction). Its inverse projects.
  glm::mat4 film_to_world() const;

  // Camera-space depth (distance along the optical axis) of a world point.
  float depth(glm::vec3 world) const { return glm::dot(world - position_, forward_); }
  // Ray parameter at which `ray` crosses the plane at camera-space depth `z` (0 if it never does
  // ahead of its origin). Used for near clipping planes.
  float t_at_depth(const scene::Ray& ray, float z) const;

  const lens::LensImaging& imaging() const { return imaging_; }
  // The imaging of a point: with a tilted lens, focused at the depth where the plane of focus
  // crosses the point's pinhole ray (its circle of confusion then follows the tilted plane);
  // else imaging().
  lens::LensImaging imaging_at(glm::vec3 world) const;
  const lens::ThinLens& lens() const { return imaging_.lens; }
  const lens::Aperture& aperture() const { return aperture_; }
  const lens::MountedLens& mounted_lens() const { return mounted_; }
  glm::vec3 position() const { return position_; }
  glm::vec3 forward() const { return forward_; }
  glm::vec3 right() const { return right_; }  // unit, the image's +x in the world
  glm::vec3 up() const { return up_; }        // unit, the image's +y (up) in the world
  int width() const { return width_; }
  int height() const { return height_; }
  // What a persistent cache's reuse rule needs of this camera.
  cache::FrameCamera frame_camera() const { return {imaging_, position_, forward_}; }

 private:
  glm::vec3 direction_to_film(glm::vec2 film) const;  // unnormalised, depth component 1
  // A real lens's film point (lens space, metres) of film position `film` (pixels), and its lens
  // ray placed in the world.
  glm::dvec2 lens_film(glm::vec2 film) const;
  LensSample placed(const lens::RealLens::Sample& s) const;
  glm::vec3 direction_of(glm::vec2 slopes) const;     // forward + slopes.x right + slopes.y up
  // The depth at which the lens rays of the pinhole direction (slopes, 1) converge: p (the
  // focus distance, or a colour band's) untilted, else where it meets the tilted plane of focus.
  double focus_depth(glm::vec2 slopes, double p) const;
  struct BandOptics {
    double focus_distance, magnification;
  };
  // Band `band`'s plane of focus and magnification (chromatic aberration; -1: the lens's own).
  BandOptics band_optics(int band) const;

  lens::LensImaging imaging_;
  lens::Aperture aperture_;  // where lens rays start: imaging_.lens.aperture's shape
  glm::vec3 position_, right_, up_, forward_;
  int width_, height_;
  float tan_half_y_, tan_half_x_;
  glm::vec2 shift_{0.0f};             // the film's shift, in slope units (lens/aperture.h)
  bool tilted_ = false;
  glm::dvec2 tilt_sin_{0.0};          // sin(tilt_x), sin(tilt_y)
  lens::MountedLens mounted_;         // a real lens, or none
};

}  // namespace dofcache::render
