#pragma once
// Thin-lens optics of the paper's section 2. All lengths in metres; depths are distances along the
// optical axis (camera-space z), which is what the thin-lens law is written in.
#include <limits>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "dofcache/lens/aperture.h"

namespace dofcache::lens {

// Eq. (2.1): thin-lens law 1/F = 1/R1 + 1/R2, solved for F given the object distance R1 and the
// image distance R2.
double focal_length_from_distances(double object_distance, double image_distance);

// Eqs. (2.2) and (2.3): the image distance V = F D / (D - F) of a point at depth D > F. With
// D = P this is V_P, the distance of the image plane (film) behind the lens.
double image_distance(double focal_length, double depth);

// Eq. (2.4): circle-of-confusion diameter on the image plane, C = |V_D - V_P| F / (n V_D).
double coc_diameter(double focal_length, double fstop, double focus_distance, double depth);

// Eq. (2.5): radius at depth D of the cone of lens rays that converge to one image point,
// r = (1/2)(F/n)|D - P|/P.
double cone_radius(double focal_length, double fstop, double focus_distance, double depth);

// Eq. (2.6): that radius projected onto the image plane, R = r V_P / D (equal to C/2).
double projected_cone_radius(double focal_length, double fstop, double focus_distance,
                             double depth);

// The lens settings: the one source of truth, passed down to cameras, caches and previews.
struct ThinLens {
  ThinLens() = default;
  ThinLens(double focal_length, double fstop, double focus_distance,
           const ApertureShape& aperture = {})
      : focal_length(focal_length), fstop(fstop), focus_distance(focus_distance),
        aperture(aperture) {}

  double focal_length = 0.05;   // F, metres
  double fstop = 4.0;           // n, so the aperture diameter is F / n
  double focus_distance = 5.0;  // P, metres from the lens to the plane in focus
  ApertureShape aperture;       // round by default (aperture.h)

  double aperture_diameter() const { return focal_length / fstop; }
  double aperture_radius() const { return 0.5 * focal_length / fstop; }
  double film_distance() const { return image_distance(focal_length, focus_distance); }  // V_P
  double coc_diameter(double depth) const;
  double cone_radius(double depth) const;

  // The stops that clip the bundle of a point off the axis (a vignetting stop, a real lens's
  // front and rear rims), seen from the aperture: each a disc of the aperture's plane, in units
  // of the aperture's radius, that the point's lens rays must start in to pass it. `slopes` is
  // the point's camera-space (x / z, y / z), `depth` its z. A disc of radius +inf is no stop
  // (the point is not beyond it, or the lens has none). The bokeh is the aperture's shape cut by
  // both (a cat's eye).
  struct StopCircle {
    glm::dvec2 centre{0.0};
    double radius = std::numeric_limits<double>::infinity();
  };
  void stop_circles(glm::dvec2 slopes, double depth, StopCircle out[2]) const;

  // Throws dofcache::Error naming the first absurd value (non-finite, non-positive, P <= F, an
  // absurd aperture shape).
  void validate() const;
  bool operator==(const ThinLens& o) const {
    return focal_length == o.focal_length && fstop == o.fstop &&
           focus_distance == o.focus_distance && aperture == o.aperture;
  }
};

// Film height i_height that gives the vertical field of view yfov with the film at distance V_P.
double film_height(double film_distance, double yfov);

// The lens and the image resolution together: what converts circles of confusion to pixels.
struct LensImaging {
  ThinLens lens;
  double yfov = 0.8;  // radians
  int y_resolution = 480;

  double pixel_pitch() const;  // i_height / y_res: size of one pixel on the film
  // Size of one pixel projected to depth D (the paper's factor1, eq. (4.1)).
  double pixel_footprint(double depth) const;
  // CoC diameter (eq. (2.4)) in pixels; signed: negative in front of the focal plane, positive
  // behind.
  double signed_coc_pixels(double depth) const;
  double coc_radius_pixels(double depth) const;
  // Inverse of signed_coc_pixels: the depth whose signed CoC is c pixels (infinite if none).
  double depth_for_signed_coc(double coc_pixels) const;
};

// The tilted plane of focus through three points (camera space: x right, y up, z forward along
// the optical axis; metres) for a lens of focal length F: the focus distance P on the axis and
// the tilts of aperture.h, whose plane is z / P - y sin(tilt_x) / F - x sin(tilt_y) / F = 1.
// Three points give three linear equations in 1 / P, sin(tilt_x) / F and sin(tilt_y) / F.
// Throws dofcache::Error (one line) if a point is not ahead of the lens, the points are (nearly)
// on one line or on a plane through the lens's centre, the plane meets the axis behind the lens
// or within its focal length, or it needs a tilt of 90 degrees or more.
struct TiltedFocus {
  double focus_distance = 0, tilt_x_deg = 0, tilt_y_deg = 0;
};
TiltedFocus focus_plane_through(const glm::dvec3 (&points)[3], double focal_length);

// Shirley-Chiu concentric mapping of the unit square to the unit disk: area preserving and low
// distortion, so stratified square samples stay stratified on the lens.
glm::vec2 concentric_disk(glm::vec2 u);
// The same mapping in polar form: the point's distance from the centre (in [0, 1]) and its angle
// as a fraction of a turn from +x (in [0, 1)). No trigonometry.
struct DiskPolar {
  float radius, turn;
};
DiskPolar concentric_polar(glm::vec2 u);

}  // namespace dofcache::lens
