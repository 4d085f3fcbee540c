#pragma once
// A real lens traced element by element (the lens-prescription issue): a LensSystem with its stop
// set to an f-number and the film placed, by tracing, where a chosen distance is in focus.
//
// Lens space: metres, the optical axis along +z towards the scene, the film plane at z = 0 and the
// rear surface's vertex at z = film_distance(). A ray from the film point (x, y, 0) leaves the
// front element as the camera ray; the lens turns the image over, so a camera maps the scene's
// right and up to the film's -x and -y.
//
// A shaped stop (blades, an anamorphic oval, an aperture image, a transmission profile) weighs
// each ray by what it passes where the ray crosses the stop (Aperture::pass); the exit-pupil
// bounds stay the round stop's, which contain every shape's.
//
// Sampling (as pbrt-v4's realistic camera): for a film point, a point is chosen uniformly on the
// bounds of the exit pupil as seen from that distance from the film centre (precomputed in
// radial bins), the ray towards it is traced, and a ray that an element stops weighs 0. The
// weight of a ray that passes is the irradiance measure cos^4(theta) A / z_rear^2 (A the bounds'
// area), divided by a normalisation: the same film distance's mean throughput by default (every
// film point then sees a uniform scene at its radiance, as through a thin lens), or the film
// centre's at the lens's widest stop when the exposure follows the lens (the image then darkens
// with the f-stop and with the lens's own vignetting, as a camera's does).
#include <array>
#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "dofcache/lens/lens_rims.h"
#include "dofcache/lens/lens_system.h"
#include "dofcache/lens/thin_lens.h"

namespace dofcache::lens {

struct LensRay {
  glm::dvec3 origin{0.0};
  glm::dvec3 direction{0.0, 0.0, 1.0};  // unit length
};

// The paraxial cardinal points of the whole lens found with traced rays near the axis, as z in lens
// space. Object distances are measured from the front principal plane, image distances from the
// rear one; the pupils are the stop's images (their diameters at the current stop).
struct CardinalPoints {
  double focal_length = 0;  // effective, metres
  double front_principal_z = 0, rear_principal_z = 0;
  double entrance_pupil_z = 0, entrance_pupil_diameter = 0;
  double exit_pupil_z = 0, exit_pupil_diameter = 0;
};

// Focus distances from here on are infinity (the lens focuses parallel rays).
constexpr double kInfiniteFocus = 1e29;

struct RealLensSettings {
  double fstop = 0;              // 0: the table's own stop
  double focus_distance = 1e30;  // metres from the film plane to the plane in focus (>= kInfiniteFocus: infinity)
  double film_radius = 0.0216;   // metres: the largest distance from the film centre rays start at
  bool exposure_follows_lens = false;
  // The stop's shape: blades, rotation, roundness, an anamorphic ratio, a profile or an aperture
  // image, inscribed in the round stop the f-number sets (lens/aperture.h; x right and y up as
  // the camera sees). Vignetting, chromatic aberration, tilt and shift are the prescription's.
  ApertureShape stop_shape;
};

class RealLens {
 public:
  // Throws dofcache::Error in one line: a table without a stop, an f-number wider than the lens's
  // widest, a focus distance the lens cannot reach (inside its own length or focal length), a
  // lens through which no ray reaches the film centre.
  RealLens(const LensSystem& system, const RealLensSettings& settings);

  // Trace through every surface, refracting (Snell) and clipping at each element's clear aperture;
  // false where an aperture or total internal reflection stops the ray. `band` -1: the glass's
  // index n_d; 0, 1, 2: red, green, blue at the Fraunhofer C, d and F lines, from the Abbe
  // numbers (no Abbe number: no dispersion). `clip` false ignores the apertures (chief rays).
  bool trace_from_film(LensRay& ray, int band = -1, bool clip = true) const;
  bool trace_from_scene(LensRay& ray, int band = -1, bool clip = true) const;

  struct Sample {
    LensRay ray;  // leaving the front element, lens space
    double weight = 0;
  };
  // The lens ray of film point `film` (lens space x, y; metres) for the sample u in [0,1)^2.
  Sample sample(glm::dvec2 film, glm::dvec2 u, int band = -1) const;
  // sample(film[i], u[i], band[i]) for i in [0, n), every output bit for bit sample()'s (a ray
  // that is stopped too: its origin and direction where it stopped). The rays cross the lens
  // kLanes at a time (a rest of four or more four at a time, the last few one by one), each
  // surface for all of them before the next: the trace of one ray is a chain of square roots,
  // each waiting for the last, and the processor overlaps the lanes' chains. Each lane does the
  // same operations in the same order as sample(), so no result changes.
  static constexpr int kLanes = 8;
  void sample_n(std::size_t n, const glm::dvec2* film, const glm::dvec2* u, const int* band,
                Sample* out) const;

  const CardinalPoints& cardinal() const { return cardinal_; }
  double film_distance() const { return film_distance_; }  // rear vertex to film
  double fstop() const { return fstop_; }
  double widest_fstop() const { return widest_fstop_; }
  double focus_distance() const { return settings_.focus_distance; }
  bool focused_at_infinity() const { return settings_.focus_distance >= kInfiniteFocus; }
  bool exposure_follows_lens() const { return settings_.exposure_follows_lens; }
  double length() const { return length_; }  // front vertex to rear vertex
  const ApertureShape& stop_shape() const { return settings_.stop_shape; }
  // The object-space angle (radians) of the chief ray, through the stop's centre, from the film
  // point at distance `height` from the centre.
  double field_angle(double height) const;
  const std::vector<LensSurface>& surfaces() const { return surfaces_; }

  // Whether any glass has an Abbe number (the colour bands then differ).
  bool dispersive() const;
  // The lens's own vignetting, the stop aside: whether every element's rim passes the film ray
  // `ray` (lens/lens_rims.h). And where the ray crosses the stop's plane, in units of the stop's
  // radius (x, y as lens space), traced without clipping; nullopt where it misses a surface.
  bool passes_rims(LensRay ray) const;
  std::optional<glm::dvec2> stop_point(LensRay ray) const;
  // Those rims as two discs at the stop, fitted once over the film (settings' film_radius).
  const RimModel& rims() const { return rims_; }

  static constexpr int kPupilBins = 64;

 private:
  struct PupilBin {
    glm::dvec2 lo{0.0}, hi{0.0};  // bounds on the rear vertex plane, film point on +x
    double throughput = 0;       // mean weight before normalisation
  };
  void tabulate();  // the per-surface numbers the traces read, after any change of a surface
  double z_of(std::size_t k) const { return film_distance_ + z_from_rear_[k]; }
  // Crosses surface k: the intersection, the clear aperture (if `clip`) and Snell's law with
  // eta = n_incident / n_transmitted (a stop only clips); false where the ray misses, is clipped
  // or reflects totally.
  bool cross(std::size_t k, glm::dvec3& origin, glm::dvec3& direction, double eta,
             bool clip) const;
  // Crosses surfaces [first, last) towards the scene (first the one nearest the film), or towards
  // the film (first the front-most), in `band`; the direction is normalised once at the end.
  bool trace_span(LensRay& ray, std::size_t first, std::size_t last, bool towards_scene, int band,
                  bool clip) const;
  // On-axis bundle from infinity: the radius of the widest parallel ray that passes.
  double marginal_height() const;
  CardinalPoints compute_cardinal() const;
  // Where an on-axis point at `distance` (lens space z; >= kInfiniteFocus: infinity) focuses best (the RMS
  // spot of a traced fan is smallest), as a z in lens space.
  double best_focus_z(double distance) const;
  void focus(double distance_from_film);
  void build_pupil_table();
  // Radial bin i of the exit-pupil table: its bounds and mean throughput at the film and stop of
  // the moment.
  PupilBin pupil_bin(int i) const;
  double raw_weight(const LensRay& from_film, double area) const;
  // sample()'s steps around the trace. aim: the ray from `film` towards a point of its exit
  // pupil's bounds for u, `w` its weight before the trace and `t` the distance from the centre in
  // bins; false where no light reaches that distance (the ray then stays as `s` holds it).
  // finish: the weight of a ray that passed with share `pass` of the stop.
  bool aim(glm::dvec2 film, glm::dvec2 u, Sample& s, double& w, double& t) const;
  double finish(double w, double pass, double t) const;
  // sample() of N film points at once: their rays aimed, then trace_through_stop for all of them
  // surface by surface (RayLanes in real_lens.cpp, structure of arrays).
  template <int N>
  struct RayLanes;
  template <int N>
  void sample_lanes(const glm::dvec2* film, const glm::dvec2* u, const int* band,
                    Sample* out) const;
  template <int N>
  void cross_lanes(std::size_t k, RayLanes<N>& r) const;
  // trace_span towards the scene with clipping, for the lanes of `r` not stopped.
  template <int N>
  void trace_span_lanes(RayLanes<N>& r, std::size_t first, std::size_t last) const;
  // trace_from_film with the stop's shape: `pass` the share the stop passes where the ray
  // crosses it (1 for a round stop); false where the ray is stopped.
  bool trace_through_stop(LensRay& ray, int band, double& pass) const;

  std::vector<LensSurface> surfaces_;
  std::vector<double> z_from_rear_;  // each surface's vertex, relative to the rear vertex
  std::vector<double> inv_radius_, half_aperture2_;  // 1 / |R| (0: flat), (aperture / 2)^2
  // [band + 1][k]: n_incident / n_transmitted at surface k for a ray from the film (the index
  // after the surface over the one before it) and from the scene (its inverse).
  std::array<std::vector<double>, 4> eta_from_film_, eta_from_scene_;
  double pupil_bins_per_metre_ = 0;
  int stop_ = -1;
  RealLensSettings settings_;
  double film_distance_ = 0, length_ = 0, fstop_ = 0, widest_fstop_ = 0;
  double normalisation_ = 1;  // the centre's throughput at the widest stop (exposure follows)
  CardinalPoints cardinal_;
  std::array<PupilBin, kPupilBins> pupil_{};
  std::optional<Aperture> stop_aperture_;  // a shaped stop; none: round
  double stop_radius_ = 0;                 // the round stop's, metres
  RimModel rims_;
};

// The sensor a real lens images onto, and which part of it an image of another aspect ratio uses:
// `inside`, the largest rectangle of the image's aspect inside the sensor (a camera's crop);
// `horizontal`, the image's width spans the sensor's; `vertical`, its height spans the sensor's.
enum class SensorFit { Inside, Horizontal, Vertical };
struct Sensor {
  double width = 0.036, height = 0.024;  // metres
  SensorFit fit = SensorFit::Inside;
  // The film's size (metres) an image of width x height pixels covers.
  glm::dvec2 film_size(int width_px, int height_px) const;
  void validate() const;  // one-line errors: non-positive or absurd sizes
  bool operator==(const Sensor& o) const {
    return width == o.width && height == o.height && fit == o.fit;
  }
};
const char* sensor_fit_name(SensorFit fit);
// "inside", "horizontal", "vertical"; throws dofcache::Error naming the choices.
SensorFit parse_sensor_fit(const std::string& name);

// What a request asks of a real lens: its prescription file (empty: the thin lens), the sensor it
// images onto and whether the exposure follows its f-stop and vignetting.
struct RealLensChoices {
  std::string file;
  Sensor sensor;
  bool exposure_follows_lens = false;
};

// A real lens as a camera mounts it: focused, its stop set, and the part of the sensor the image
// covers. The camera node is the sensor plane.
struct MountedLens {
  std::shared_ptr<const RealLens> lens;
  glm::dvec2 film_size{0.0};  // metres
  std::string source;         // the lens file (messages, cache files)

  explicit operator bool() const { return lens != nullptr; }
  // The thin lens a cache's reuse rule and a preview see: the effective focal length, the f-number
  // of the entrance pupil, and the focus distance measured from the front principal plane (the
  // thick-lens law, which the traced bokeh follows: tests/lens/real_lens_test.cpp), its stop's
  // shape, and its rims as that thin lens's stops (lens_rims.h), which the preview draws.
  ThinLens equivalent() const;
  // The paraxial vertical field of view: the film's height over the image distance behind the
  // rear principal plane.
  double yfov() const;
  // The paraxial fields of view across and up the film (radians): yfov() and the film's width
  // over the same image distance.
  glm::dvec2 field_of_view() const;
  // The front principal plane's distance in front of the sensor: where the equivalent thin lens
  // sits (read per lens ray).
  double principal_offset() const { return lens->cardinal().front_principal_z; }
  // How far the lens is from a perspective projection at the film's corner: |V tan(theta) / r - 1|
  // for the chief ray's object-space angle theta from the corner at r, V the image distance
  // (0.015 for the shipped 28 mm; a fisheye's is large, infinite from 90 degrees on).
  double corner_distortion() const;
};

// Mounts `system` (read from `source`) focused at `focus_distance` from the sensor with `fstop`
// (0: the table's stop) on `sensor` for an image of width x height pixels. Lenses are kept, so a
// second request for the same lens and settings (a viewer's pass, a sequence's repeated focus)
// does not rebuild its exit-pupil table. Throws dofcache::Error (RealLens's errors).
MountedLens mount_lens(const std::shared_ptr<const LensSystem>& system, const std::string& source,
                       double fstop, double focus_distance, const Sensor& sensor, int width,
                       int height, bool exposure_follows_lens, const ApertureShape& stop = {});

// LensSystem::read, kept per path, size and modification time (as aperture images are); where no
// file `path` exists, the shipped lens it names (lens/shipped_lenses.h).
std::shared_ptr<const LensSystem> read_lens_file(const std::string& path);

}  // namespace dofcache::lens
