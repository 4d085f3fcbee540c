#pragma once
// The aperture's shape: round, or a polygon of `blades` straight or curved blades, rotated, and
// squeezed by an anamorphic ratio. A defocused point's bokeh is this shape scaled by its circle of
// confusion (behind the focal plane upright in the image, in front of it turned by 180 degrees),
// so shaped highlights come from sampling lens rays over it.
//
// Geometry, in units of the round aperture's radius (F / 2n) and in the image's orientation (x
// right, y up):
//   * blades N >= 3: a regular N-gon inscribed in the unit circle, a corner at `rotation_deg`
//     from +x counter-clockwise; its rim at angle t from the nearest edge's normal lies at
//     cos(pi / N) / cos(t) (Cycles counts its blades' rotation from another axis: the peer
//     benchmark maps it);
//   * roundness r in [0, 1]: the rim's distance blended with the circle's, (1 - r) polygon + r;
//   * anamorphic ratio q: the bokeh's height over its width, the larger axis kept at the
//     f-number's diameter (x scaled by min(1, 1/q), y by min(1, q)).
// The exposure stays the round lens's: every lens ray weighs the same whatever the shape's area.
//
// A vignetting stop (optical vignetting) is a second circular stop of radius R at distance D in
// front of the aperture, centred on the optical axis. Off axis it clips the bundle of lens rays:
// seen from an image point, the rays that pass are those through the aperture and the stop's
// shadow on it, a disc of radius R P / (P - D) shifted against the image point's direction by
// D / (P - D) of its focus point's offset (P the focus distance). Its bokeh is the intersection
// of two discs, the cat's eye; the image darkens towards the corners as a real lens's does.
//
// Chromatic aberration colours the bokeh's rims: each lens ray carries one of three wavelength
// bands (red, green, blue: renderer.cpp picks them), and the band's rays focus `axial_ca` metres
// apart between the red and blue ends (red farther; green at the focus distance) and image the
// scene `lateral_ca` larger in red than in blue (relative magnification; green unchanged), so
// fringes appear where the bands' rays part: defocused edges and the frame's corners.
//
// A transmission profile multiplies whichever shape is set: a lens ray at normalised radius rho
// (its distance from the centre over the rim's in its direction, 0 to 1) is weighted by T(rho)
// over T's mean over the shape, so the exposure stays the uniform aperture's. Centre-weighted:
// T = 1 - s rho^2 (soft, "smooth trans focus" bokeh); rim-weighted: T = 1 - s + s rho^2 (the
// bright-rimmed "soap bubble" bokeh of some old lenses); s the strength in [0, 1]. Sampled
// uniformly over the shape, rho has the density 2 rho whatever the shape (it is star-shaped
// about its centre), so T's mean is 1 - s / 2 for both.
//
// An aperture image (`image`, a PNG or EXR path) replaces blades and roundness: its grey values
// (the mean of its channels) are the transmission over the square around the round aperture,
// x right and the top row up, and lens rays are importance-sampled in proportion to them (as
// pbrt-v4 does), each of weight 1. The anamorphic squeeze, the profile, the stop, chromatic
// aberration and tilt-shift still apply.
//
// Tilt and shift (a tilt-shift lens; ApertureShape carries them with the rest of the lens's
// character). Shift moves the film parallel to itself: the view moves by shift_x, shift_y image
// heights (right, up) without turning the camera, so verticals stay parallel. Tilt turns the lens
// by tilt_x degrees about the horizontal axis (positive: the plane of focus reaches down, towards
// a floor) and tilt_y about the vertical one (positive: towards the left). By the Scheimpflug
// and hinge rules the plane of focus then passes through the point in focus on the axis, at P,
// and through the hinge line at J = F / sin(tilt) from the lens: in camera space (x right, y up,
// z forward) it is z / P - y sin(tilt_x) / F - x sin(tilt_y) / F = 1. The aperture stays
// perpendicular to the axis (a thin-lens approximation).
#include <algorithm>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <glm/vec2.hpp>

namespace dofcache::lens {

constexpr int kMinBlades = 3, kMaxBlades = 16;
// Chords per half-blade of a rounded blade's rim (aperture.cpp).
constexpr int kRimSegments = 32;

enum class ApertureProfile { Uniform, Centre, Rim };
ApertureProfile parse_aperture_profile(const std::string& name);  // throws dofcache::Error
const char* aperture_profile_name(ApertureProfile profile);

// A vignetting stop (see above); radius 0: none.
struct VignettingStop {
  double radius = 0.0;    // metres
  double distance = 0.0;  // metres in front of the aperture, along the optical axis
  bool operator==(const VignettingStop& o) const {
    return radius == o.radius && distance == o.distance;
  }
};

// A real lens's own optical vignetting as its thin-lens equivalent draws it (lens/lens_rims.h):
// the rims in front of its stop and behind it, each as a circular stop. `front` clips as a
// vignetting stop does; `rear` lies `distance` behind the aperture, towards the film, and clips
// the other side of an off-axis bundle. `normalised`: the image is divided by what they pass (a
// real lens whose exposure does not follow it), so a cat's eye keeps a round bokeh's light. Not
// a choice of the command line: MountedLens::equivalent sets it from the traced lens, and the
// preview draws it (the traced lens's own rays need no model).
struct LensRims {
  VignettingStop front, rear;
  bool normalised = false;
  bool any() const { return front.radius > 0.0 || rear.radius > 0.0; }
  bool operator==(const LensRims& o) const {
    return front == o.front && rear == o.rear && normalised == o.normalised;
  }
};

struct ApertureShape {
  ApertureShape() = default;
  ApertureShape(int blades, double rotation_deg, double roundness, double anamorphic_ratio,
                VignettingStop stop = {}, double axial_ca = 0.0, double lateral_ca = 0.0,
                ApertureProfile profile = ApertureProfile::Uniform, double profile_strength = 1.0,
                double tilt_x_deg = 0.0, double tilt_y_deg = 0.0, double shift_x = 0.0,
                double shift_y = 0.0, std::string image = {})
      : blades(blades), rotation_deg(rotation_deg), roundness(roundness),
        anamorphic_ratio(anamorphic_ratio), stop(stop), axial_ca(axial_ca),
        lateral_ca(lateral_ca), profile(profile), profile_strength(profile_strength),
        tilt_x_deg(tilt_x_deg), tilt_y_deg(tilt_y_deg), shift_x(shift_x), shift_y(shift_y),
        image(std::move(image)) {}

  int blades = 0;                 // 0: round; else kMinBlades..kMaxBlades
  double rotation_deg = 0.0;      // a corner's angle from the image's +x, counter-clockwise
  double roundness = 0.0;         // 0: straight blades, 1: round
  double anamorphic_ratio = 1.0;  // the bokeh's height over its width
  VignettingStop stop;            // none by default
  double axial_ca = 0.0;          // metres between the red and blue planes of focus
  double lateral_ca = 0.0;        // red's magnification over blue's, minus 1
  ApertureProfile profile = ApertureProfile::Uniform;
  double profile_strength = 1.0;  // s in [0, 1]
  double tilt_x_deg = 0.0, tilt_y_deg = 0.0;  // lens tilt about the horizontal, vertical axes
  double shift_x = 0.0, shift_y = 0.0;        // film shift, in image heights
  std::string image;                          // an aperture image's path; empty: none
  LensRims rims;                              // a real lens's equivalent's; none by default

  // Whether every lens ray lands where a round aperture's would (blades 0, ratio 1).
  bool round() const { return blades == 0 && anamorphic_ratio == 1.0 && image.empty(); }
  bool vignetting() const { return stop.radius > 0.0; }
  bool chromatic() const { return axial_ca != 0.0 || lateral_ca != 0.0; }
  bool weighted() const { return profile != ApertureProfile::Uniform && profile_strength > 0.0; }
  bool tilted() const { return tilt_x_deg != 0.0 || tilt_y_deg != 0.0; }
  bool shifted() const { return shift_x != 0.0 || shift_y != 0.0; }
  // The ideal lens of before shapes: round, nothing clipped, every colour alike, every lens ray
  // of the same weight.
  bool plain() const {
    return round() && !vignetting() && !chromatic() && !weighted() && !tilted() && !shifted() &&
           !rims.any();
  }
  // A lens ray's weight at normalised radius rho: T(rho) over T's mean (1 without a profile).
  double transmission(double rho) const;
  // Band b's (0 red, 1 green, 2 blue) place between the red (+1/2) and blue (-1/2) ends.
  static double band_position(int band) { return 0.5 * (1 - band); }
  // The shape's nearest rim point: its inradius over the round aperture's radius. A footprint
  // this large lies within the bokeh in every direction.
  double inner_scale() const;
  // The radiance cache's reuse footprint, an oval within the bokeh: its larger semi-axis over the
  // round aperture's radius (the polygon's inradius, before the anamorphic squeeze), and the
  // squeeze along x and y (each at most 1; inner_scale() = footprint_scale() times the smaller).
  double footprint_scale() const;
  glm::dvec2 footprint_squeeze() const {
    return {std::min(1.0, 1.0 / anamorphic_ratio), std::min(1.0, anamorphic_ratio)};
  }
  // Throws dofcache::Error naming the first absurd value (1-2 or more than kMaxBlades blades,
  // roundness outside [0, 1], a ratio <= 0 or non-finite, a non-finite rotation, a vignetting
  // stop whose radius or distance is not positive and finite, a lateral chromatic aberration
  // beyond 20 % or either aberration not finite, a profile strength outside [0, 1], a tilt of 90
  // degrees or more, a shift beyond one image height, a rim whose radius or distance is not
  // positive and finite, rims with a vignetting stop).
  void validate() const;
  bool operator==(const ApertureShape& o) const {
    return blades == o.blades && rotation_deg == o.rotation_deg && roundness == o.roundness &&
           anamorphic_ratio == o.anamorphic_ratio && stop == o.stop &&
           axial_ca == o.axial_ca && lateral_ca == o.lateral_ca && profile == o.profile &&
           profile_strength == o.profile_strength && tilt_x_deg == o.tilt_x_deg &&
           tilt_y_deg == o.tilt_y_deg && shift_x == o.shift_x && shift_y == o.shift_y &&
           image == o.image && rims == o.rims;
  }
};

// A blade count read as a number (JSON and glTF store numbers): the count if the number is whole
// and within an int's reach, else nullopt. ApertureShape::validate judges the count.
std::optional<int> blade_count(double value);

// The shape's values as given somewhere (the command line, a request, a glTF camera's
// extras.lens, a camera path's key): each unset one falls back to the next source.
struct ApertureChoices {
  std::optional<int> blades;
  std::optional<double> rotation_deg, roundness, anamorphic_ratio;
  std::optional<VignettingStop> vignetting_stop;
  std::optional<double> axial_ca, lateral_ca;
  std::optional<ApertureProfile> profile;
  std::optional<double> profile_strength;
  std::optional<std::pair<double, double>> lens_tilt, lens_shift;  // (x, y)
  std::optional<std::string> image;

  // Each value from here, else from `fallback`.
  ApertureChoices over(const ApertureChoices& fallback) const;
  // The shape with the unset values at their defaults (round).
  ApertureShape shape() const;
  // A resolved shape as choices (what a printed request keeps): every scalar set, the stop, tilt,
  // shift and image only where the shape has them. of(s).shape() == s (a real lens's rims are
  // not a choice: of() leaves them out).
  static ApertureChoices of(const ApertureShape& s);
  bool any() const {
    return blades || rotation_deg || roundness || anamorphic_ratio || vignetting_stop ||
           axial_ca || lateral_ca || profile || profile_strength || lens_tilt || lens_shift ||
           image;
  }
};

// The largest aperture image read (pixels): a transmission map needs no more.
constexpr int kMaxApertureImageSide = 4096;

class Aperture {
 public:
  // Validates; reads the aperture image if the shape names one (throws dofcache::Error, one line
  // naming the file, if it is unreadable, larger than kMaxApertureImageSide a side, or black).
  explicit Aperture(const ApertureShape& shape = {});

  // A point of the aperture for u in [0, 1)^2, uniform over its area: the round aperture's
  // concentric mapping (concentric_disk) exactly; a polygon by the fan of triangles from the
  // centre to its rim, entered through the concentric mapping's polar form (concentric_polar):
  // its turn picks a triangle in proportion to its area and the point along its outer edge, its
  // distance from the centre the distance (no trigonometry). Straight blades are
  // their N triangles exactly; a rounded blade's rim is 2 x kRimSegments chords, which lie within
  // 2e-4 of its radius (a hundredth of a pixel for a bokeh 50 pixels across).
  // With `rho`, also the point's normalised radius (its distance over the rim's in its
  // direction): the disc's distance from the centre, in the fan as on the disc.
  glm::vec2 sample(glm::vec2 u, float* rho = nullptr) const;
  // The rim's distance from the centre in the direction `angle` (radians, from +x
  // counter-clockwise).
  double rim(double angle) const;  // blades and ovals (an aperture image's rim is not traced)
  bool contains(glm::vec2 p) const;
  // The share of light the aperture passes at p (in sample()'s units and orientation): 0 outside
  // its shape, 1 inside (an aperture image: its grey level over its brightest), times the
  // profile's T(rho) as a filter would pass it (not divided by its mean). A real lens's stop
  // weighs its traced rays by it (lens/real_lens.h).
  double pass(glm::vec2 p) const;
  const ApertureShape& shape() const { return shape_; }
  // The aperture image's sampling tables (opaque: aperture.cpp), read once per file and shared
  // by every Aperture (and camera) that names it.
  struct ImageTables;

 private:
  double polygon_rim(double angle) const;  // before the anamorphic squeeze

  ApertureShape shape_;
  glm::vec2 squeeze_{1.0f, 1.0f};
  // The fan's rim points counter-clockwise, squeezed, the first repeated at the end, and the
  // cumulative share of the area up to each (0 first, 1 last).
  std::vector<glm::vec2> rim_points_;
  std::vector<float> area_cdf_;
  std::shared_ptr<const ImageTables> image_;
  glm::vec2 sample_image(glm::vec2 u) const;
  // The image's grey level over its brightest at p, unsqueezed, in the round aperture's units.
  float transmission_at(glm::vec2 p) const;
};

}  // namespace dofcache::lens
