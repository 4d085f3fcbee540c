#include "dofcache/lens/real_lens.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>

#include <glm/geometric.hpp>
#include <tbb/parallel_for.h>

#include "dofcache/core/error.h"
#include "dofcache/core/shared_cache.h"
#include "dofcache/lens/shipped_lenses.h"

namespace dofcache::lens {
namespace {

constexpr int kBoundsGrid = 48;     // per axis, the exit-pupil search over the rear element
constexpr int kThroughputGrid = 64;  // per axis, the mean weight of one radial bin

// Fraunhofer C, d and F lines (micrometres): the red, green and blue bands' wavelengths.
constexpr double kLambda[3] = {0.65627, 0.58756, 0.48613};

std::string mm(double metres) { return std::to_string(metres * 1e3).substr(0, 8) + " mm"; }

// What a real lens's stop may take of the aperture options; the rest is the prescription's.
void check_stop_shape(const ApertureShape& shape) {
  if (shape.vignetting() || shape.chromatic() || shape.tilted() || shape.shifted())
    throw Error("a real lens's vignetting, chromatic aberration, tilt and shift come from its "
                "prescription; its stop takes blades, rotation, roundness, an anamorphic ratio, a "
                "profile or an aperture image");
}

// Where a ray crosses the axis plane y = 0 of its meridional section (its x reaches 0) and where it
// reaches height h: the z of each, for the cardinal points.
double z_at_x(const LensRay& r, double x) {
  return r.origin.z + (x - r.origin.x) / r.direction.x * r.direction.z;
}

}  // namespace

RealLens::RealLens(const LensSystem& system, const RealLensSettings& settings)
    : surfaces_(system.surfaces()), stop_(system.stop_index()), settings_(settings) {
  if (stop_ < 0)
    throw Error("the lens table has no aperture stop (a row with radius 0 and index 0)");
  if (!(settings.film_radius > 0.0 && settings.film_radius < 1.0))
    throw Error("the film's half-diagonal must be in (0, 1) m");
  if (!(settings.focus_distance > 0.0) || std::isnan(settings.focus_distance))
    throw Error("the focus distance must be positive");
  if (!(settings.fstop >= 0.0) || !std::isfinite(settings.fstop))
    throw Error("the f-number must be positive");
  const ApertureShape& shape = settings.stop_shape;
  check_stop_shape(shape);
  tabulate();
  z_from_rear_.assign(surfaces_.size(), 0.0);
  for (std::size_t k = surfaces_.size() - 1; k-- > 0;)
    z_from_rear_[k] = z_from_rear_[k + 1] + surfaces_[k].thickness;
  length_ = z_from_rear_.front();
  // The table's own stop: the widest f-number. Focus at infinity first (cardinal points do not
  // depend on where the film is).
  film_distance_ = 0.0;
  cardinal_ = compute_cardinal();
  if (!(cardinal_.focal_length > 0.0))
    throw Error("the lens does not form a real image (effective focal length " +
                mm(cardinal_.focal_length) + ")");
  widest_fstop_ = cardinal_.focal_length / cardinal_.entrance_pupil_diameter;
  fstop_ = settings.fstop > 0.0 ? settings.fstop : widest_fstop_;
  if (fstop_ < widest_fstop_ * (1.0 - 1e-6))
    throw Error("f/" + std::to_string(fstop_).substr(0, 5) + " is wider than the lens's widest, f/" +
                std::to_string(widest_fstop_).substr(0, 5));
  if (fstop_ > 1000.0) throw Error("an f-number above 1000");
  if (settings.exposure_follows_lens) {
    // A camera's exposure: the film centre's throughput wide open and focused at infinity.
    focus(kInfiniteFocus);
    normalisation_ = pupil_bin(0).throughput;
  }
  // The pupil scales with the stop paraxially; the marginal ray's aberrations need a few rounds.
  const double target = fstop_;
  fstop_ = widest_fstop_;  // what the table's stop gives
  film_distance_ = 0.0;
  for (int i = 0; i < 8 && std::abs(fstop_ / target - 1.0) > 1e-4; ++i) {
    surfaces_[stop_].aperture_diameter *= fstop_ / target;
    tabulate();
    cardinal_ = compute_cardinal();
    fstop_ = cardinal_.focal_length / cardinal_.entrance_pupil_diameter;
  }
  focus(settings.focus_distance);
  // The shape after the exposure's normalisation: a camera's is the lens wide open, its blades
  // drawn back.
  stop_radius_ = 0.5 * surfaces_[stop_].aperture_diameter;
  if (!(shape == ApertureShape{})) stop_aperture_.emplace(shape);  // validates; reads an image
  build_pupil_table();
  if (!(pupil_[0].throughput > 0.0)) throw Error("no ray through the lens reaches the film centre");
  if (!settings.exposure_follows_lens) normalisation_ = 0.0;  // per radius, below
  rims_ = fit_rims(*this, settings.film_radius);  // kept with the lens: mounting it again is free
}

void RealLens::tabulate() {
  const std::size_t count = surfaces_.size();
  inv_radius_.assign(count, 0.0);
  half_aperture2_.assign(count, 0.0);
  for (std::size_t k = 0; k < count; ++k) {
    const LensSurface& s = surfaces_[k];
    if (s.radius != 0.0) inv_radius_[k] = 1.0 / std::abs(s.radius);
    half_aperture2_[k] = 0.25 * s.aperture_diameter * s.aperture_diameter;
  }
  for (int band = -1; band < 3; ++band) {
    std::vector<double> n(count + 1, 1.0);  // n[k + 1]: after surface k; n[0]: the scene's air
    for (std::size_t k = 0; k < count; ++k) {
      const LensSurface& s = surfaces_[k];
      n[k + 1] = s.ior;
      if (band < 0 || s.abbe <= 0.0 || s.ior == 1.0) continue;
      // Cauchy's n = A + B / lambda^2 through n_d, with n_F - n_C = (n_d - 1) / V_d.
      const double b = (s.ior - 1.0) / s.abbe /
                       (1.0 / (kLambda[2] * kLambda[2]) - 1.0 / (kLambda[0] * kLambda[0]));
      n[k + 1] += b * (1.0 / (kLambda[band] * kLambda[band]) - 1.0 / (kLambda[1] * kLambda[1]));
    }
    // A camera ray crosses surface k from the medium after it into the one before it.
    std::vector<double>& from_film = eta_from_film_[band + 1];
    std::vector<double>& from_scene = eta_from_scene_[band + 1];
    from_film.resize(count);
    from_scene.resize(count);
    for (std::size_t k = 0; k < count; ++k) {
      from_film[k] = n[k + 1] / n[k];
      from_scene[k] = n[k] / n[k + 1];
    }
  }
}

bool RealLens::cross(std::size_t k, glm::dvec3& o, glm::dvec3& d, double eta, bool clip) const {
  const LensSurface& s = surfaces_[k];
  const double zk = z_of(k);
  glm::dvec3 n;
  if (s.radius == 0.0) {
    const double t = (zk - o.z) / d.z;
    if (!(t > 0.0)) return false;
    o += t * d;
    n = {0.0, 0.0, d.z > 0.0 ? -1.0 : 1.0};
  } else {
    // The sphere's centre lies on the axis at z_k - R (positive R: towards the film). Of its two
    // crossings the surface is the one on the vertex's side of the centre.
    const glm::dvec3 oc{o.x, o.y, o.z - (zk - s.radius)};
    const double b = glm::dot(oc, d);
    const double disc = b * b - (glm::dot(oc, oc) - s.radius * s.radius);
    if (disc < 0.0) return false;
    const double root = std::sqrt(disc);
    const double t = (d.z > 0.0) == (s.radius < 0.0) ? -b - root : -b + root;
    if (!(t > 0.0)) return false;
    o += t * d;
    n = (oc + t * d) * inv_radius_[k];  // unit; either sign
    if (glm::dot(n, d) > 0.0) n = -n;
  }
  if (clip && o.x * o.x + o.y * o.y > half_aperture2_[k]) return false;
  if (s.stop) return true;
  // Snell's law with eta = eta_i / eta_t. Refracting a unit vector about a unit normal keeps it
  // unit to rounding: the traces normalise once at the end.
  const double cos_i = -glm::dot(n, d);
  const double sin2_t = eta * eta * std::max(0.0, 1.0 - cos_i * cos_i);
  if (sin2_t >= 1.0) return false;  // total internal reflection
  d = eta * d + (eta * cos_i - std::sqrt(1.0 - sin2_t)) * n;
  return true;
}

bool RealLens::trace_span(LensRay& ray, std::size_t first, std::size_t last, bool towards_scene,
                          int band, bool clip) const {
  const std::size_t b = band < 0 || band > 2 ? 0 : band + 1;
  if (towards_scene) {
    const double* eta = eta_from_film_[b].data();
    for (std::size_t k = last; k-- > first;)
      if (!cross(k, ray.origin, ray.direction, eta[k], clip)) return false;
  } else {
    const double* eta = eta_from_scene_[b].data();
    for (std::size_t k = first; k < last; ++k)
      if (!cross(k, ray.origin, ray.direction, eta[k], clip)) return false;
  }
  ray.direction = glm::normalize(ray.direction);
  return true;
}

bool RealLens::trace_from_film(LensRay& ray, int band, bool clip) const {
  return trace_span(ray, 0, surfaces_.size(), true, band, clip);
}

bool RealLens::trace_from_scene(LensRay& ray, int band, bool clip) const {
  return trace_span(ray, 0, surfaces_.size(), false, band, clip);
}

double RealLens::marginal_height() const {
  const double front = z_of(0) + 1.0;
  auto passes = [&](double h) {
    LensRay r{{h, 0.0, front}, {0.0, 0.0, -1.0}};
    return trace_from_scene(r);
  };
  double lo = 0.0, hi = 0.5 * surfaces_.front().aperture_diameter;
  if (passes(hi)) return hi;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (passes(mid) ? lo : hi) = mid;
  }
  return lo;
}

CardinalPoints RealLens::compute_cardinal() const {
  CardinalPoints c;
  const double h = 1e-3 * marginal_height();
  if (!(h > 0.0)) throw Error("no ray parallel to the axis passes the lens");
  // A ray parallel to the axis from the scene crosses the axis at the rear focal point; the
  // extensions of its entering and leaving parts meet on the rear principal plane.
  LensRay in{{h, 0.0, z_of(0) + 1.0}, {0.0, 0.0, -1.0}};
  if (!trace_from_scene(in)) throw Error("a paraxial ray does not pass the lens");
  const double rear_focal_z = z_at_x(in, 0.0);
  c.rear_principal_z = z_at_x(in, h);
  c.focal_length = c.rear_principal_z - rear_focal_z;
  // The same from the film side: the front principal plane.
  LensRay out{{h, 0.0, z_of(surfaces_.size() - 1) - 1.0}, {0.0, 0.0, 1.0}};
  if (!trace_from_film(out)) throw Error("a paraxial ray does not pass the lens backwards");
  c.front_principal_z = z_at_x(out, h);
  // The pupils: a ray from the stop's centre at a small angle, through the front group to the
  // scene (its extension meets the axis at the entrance pupil) and through the rear group to the
  // film (the exit pupil). The pupil magnification is the ratio of its slopes.
  const double a = 1e-4;
  const std::size_t stop = static_cast<std::size_t>(stop_);
  auto through = [&](bool towards_scene) {
    LensRay r{{0.0, 0.0, z_of(stop)}, glm::normalize(glm::dvec3{a, 0.0, towards_scene ? 1 : -1})};
    const bool passed = towards_scene ? trace_span(r, 0, stop, true, -1, false)
                                      : trace_span(r, stop + 1, surfaces_.size(), false, -1, false);
    if (!passed) throw Error("a paraxial chief ray does not pass the lens");
    return r;
  };
  const LensRay front = through(true), rear = through(false);
  c.entrance_pupil_z = z_at_x(front, 0.0);
  c.exit_pupil_z = z_at_x(rear, 0.0);
  c.entrance_pupil_diameter = 2.0 * marginal_height();
  c.exit_pupil_diameter = c.entrance_pupil_diameter * std::abs((front.direction.x / front.direction.z) /
                                                               (rear.direction.x / rear.direction.z));
  return c;
}

double RealLens::best_focus_z(double distance) const {
  constexpr int kFan = 1024;
  const double front_half = 0.5 * surfaces_.front().aperture_diameter;
  double sab = 0.0, sbb = 0.0;
  for (int i = 0; i < kFan; ++i) {
    const double h = (i + 0.5) / kFan * front_half;
    LensRay r;
    if (distance >= kInfiniteFocus) {
      r = {{0.0, h, z_of(0) + 1.0}, {0.0, 0.0, -1.0}};
    } else {
      r.origin = {0.0, 0.0, distance};
      r.direction = glm::normalize(glm::dvec3{0.0, h, z_of(0)} - r.origin);
    }
    if (!trace_from_scene(r)) continue;
    // y(z) = a + b z along the leaving ray; a ring of height h weighs h.
    const double b = r.direction.y / r.direction.z;
    const double a = r.origin.y - r.origin.z * b;
    sab += h * a * b;
    sbb += h * b * b;
  }
  if (!(sbb > 0.0)) throw Error("no ray from the focus distance passes the lens");
  return -sab / sbb;
}

void RealLens::focus(double distance) {
  // The thick-lens focus first: with a = object distance from the front principal plane and b =
  // image distance from the rear one, a + b = T (the distance minus the hiatus) and ab = f T.
  const double f = cardinal_.focal_length;
  const double zh = cardinal_.front_principal_z - film_distance_;   // from the rear vertex
  const double zh2 = cardinal_.rear_principal_z - film_distance_;
  double b = f;
  if (distance < kInfiniteFocus) {
    const double t = distance - zh + zh2;
    if (!(t > 4.0 * f) || distance <= length_)
      throw Error("the lens cannot focus at " + std::to_string(distance).substr(0, 8) +
                  " m from the film (its closest is about " +
                  std::to_string(4.0 * f + zh - zh2).substr(0, 8) + " m)");
    b = 0.5 * (t - std::sqrt(t * (t - 4.0 * f)));
  }
  film_distance_ = b - zh2;
  // Then by tracing: move the film to where the traced bundle's RMS spot is smallest.
  for (int i = 0; i < 30; ++i) {
    const double z = best_focus_z(distance);
    film_distance_ -= z;
    if (std::abs(z) < 1e-10) break;
  }
  if (!(film_distance_ > 0.0))
    throw Error("the lens focuses inside itself (back focus " + mm(film_distance_) + ")");
  cardinal_ = compute_cardinal();  // the same points, now placed relative to the film
}

double RealLens::raw_weight(const LensRay& from_film, double area) const {
  const double c = from_film.direction.z;
  const double z = z_of(surfaces_.size() - 1);
  return c * c * c * c * area / (z * z);
}

bool RealLens::trace_through_stop(LensRay& ray, int band, double& pass) const {
  pass = 1.0;
  if (!stop_aperture_) return trace_from_film(ray, band);
  const std::size_t stop = static_cast<std::size_t>(stop_);
  if (!trace_span(ray, stop, surfaces_.size(), true, band, true)) return false;  // to the stop
  pass = stop_aperture_->pass(glm::vec2(static_cast<float>(ray.origin.x / stop_radius_),
                                        static_cast<float>(ray.origin.y / stop_radius_)));
  return pass > 0.0 && trace_span(ray, 0, stop, true, band, true);
}

void RealLens::build_pupil_table() {
  pupil_bins_per_metre_ = kPupilBins / settings_.film_radius;
  tbb::parallel_for(0, kPupilBins, [&](int i) { pupil_[i] = pupil_bin(i); });
}

RealLens::PupilBin RealLens::pupil_bin(int i) const {
  const double rear_half = 0.5 * surfaces_.back().aperture_diameter * 1.5;
  const double z_rear = z_of(surfaces_.size() - 1);
  PupilBin bin;
  const double r0 = settings_.film_radius * i / kPupilBins;
  const double r1 = settings_.film_radius * (i + 1) / kPupilBins;
  glm::dvec2 lo{std::numeric_limits<double>::max()}, hi{-std::numeric_limits<double>::max()};
  const double cell = 2.0 * rear_half / kBoundsGrid;
  for (double x : {r0, 0.5 * (r0 + r1), r1})
    for (int gy = 0; gy <= kBoundsGrid; ++gy)
      for (int gx = 0; gx <= kBoundsGrid; ++gx) {
        const glm::dvec2 q{-rear_half + gx * cell, -rear_half + gy * cell};
        LensRay r{{x, 0.0, 0.0}, glm::normalize(glm::dvec3{q.x - x, q.y, z_rear})};
        if (!trace_from_film(r)) continue;
        lo = glm::min(lo, q);
        hi = glm::max(hi, q);
      }
  if (!(lo.x <= hi.x)) return bin;  // no light at this distance from the centre
  // One cell of margin: the grid can miss a sliver of the pupil.
  bin.lo = glm::max(lo - cell, glm::dvec2{-rear_half});
  bin.hi = glm::min(hi + cell, glm::dvec2{rear_half});
  const double area = (bin.hi.x - bin.lo.x) * (bin.hi.y - bin.lo.y);
  const double x = 0.5 * (r0 + r1) * (i == 0 ? 0.0 : 1.0);  // bin 0: the centre itself
  double sum = 0.0;
  for (int gy = 0; gy < kThroughputGrid; ++gy)
    for (int gx = 0; gx < kThroughputGrid; ++gx) {
      const glm::dvec2 q = bin.lo + (glm::dvec2{gx + 0.5, gy + 0.5} / double(kThroughputGrid)) *
                                        (bin.hi - bin.lo);
      LensRay r{{x, 0.0, 0.0}, glm::normalize(glm::dvec3{q.x - x, q.y, z_rear})};
      const double w = raw_weight(r, area);
      double pass = 1.0;
      if (trace_through_stop(r, -1, pass)) sum += w * pass;
    }
  bin.throughput = sum / (kThroughputGrid * kThroughputGrid);
  return bin;
}

bool RealLens::aim(glm::dvec2 film, glm::dvec2 u, Sample& s, double& w, double& t) const {
  s.ray.origin = {film.x, film.y, 0.0};
  const double r = std::sqrt(film.x * film.x + film.y * film.y);
  t = r * pupil_bins_per_metre_;
  const int i = std::min(static_cast<int>(t), kPupilBins - 1);
  const PupilBin& bin = pupil_[i];
  if (!(bin.throughput > 0.0)) return false;
  glm::dvec2 q = bin.lo + u * (bin.hi - bin.lo);
  if (r > 0.0) {  // the bins hold film points on +x: turn to this one's angle
    const double inv = 1.0 / r;
    const double c = film.x * inv, sn = film.y * inv;
    q = {q.x * c - q.y * sn, q.x * sn + q.y * c};
  }
  const double area = (bin.hi.x - bin.lo.x) * (bin.hi.y - bin.lo.y);
  s.ray.direction = glm::normalize(glm::dvec3{q.x - film.x, q.y - film.y, z_of(surfaces_.size() - 1)});
  w = raw_weight(s.ray, area);
  return true;
}

double RealLens::finish(double w, double pass, double t) const {
  w *= pass;
  double norm = normalisation_;
  if (norm == 0.0) {
    // The mean throughput at this distance from the centre: linear between the bins' centres (bin 0
    // holds the centre itself).
    const double x = std::clamp(t - 0.5, 0.0, kPupilBins - 1.0);
    const int j = std::min(static_cast<int>(x), kPupilBins - 2);
    const double f = x - j;
    norm = (1.0 - f) * pupil_[j].throughput + f * pupil_[j + 1].throughput;
  }
  return norm > 0.0 ? w / norm : 0.0;
}

RealLens::Sample RealLens::sample(glm::dvec2 film, glm::dvec2 u, int band) const {
  Sample s;
  double w = 0.0, t = 0.0, pass = 1.0;
  if (!aim(film, u, s, w, t) || !trace_through_stop(s.ray, band, pass)) return s;
  s.weight = finish(w, pass, t);
  return s;
}

// N rays as structure of arrays: the loops over lanes are short, independent and alike, so the
// processor overlaps them. A lane that is stopped keeps its origin and direction as the scalar
// trace leaves them (cross() writes the origin before the clip and the direction last) and is
// skipped from then on.
template <int N>
struct RealLens::RayLanes {
  double ox[N], oy[N], oz[N], dx[N], dy[N], dz[N];
  const double* eta[N];  // per surface, the lane's band's (from the film)
  bool live[N];

  bool any() const {
    bool a = false;
    for (int l = 0; l < N; ++l) a |= live[l];
    return a;
  }
  // glm::normalize of the live lanes' directions, as trace_span ends: d * (1 / sqrt(d . d)).
  void normalise() {
    for (int l = 0; l < N; ++l) {
      if (!live[l]) continue;
      const double inv = 1.0 / std::sqrt(dx[l] * dx[l] + dy[l] * dy[l] + dz[l] * dz[l]);
      dx[l] *= inv, dy[l] *= inv, dz[l] *= inv;
    }
  }
};

// cross() for every lane towards the scene with clipping, written out per component in glm's
// order of operations (a dot product is (x x' + y y') + z z').
template <int N>
void RealLens::cross_lanes(std::size_t k, RayLanes<N>& r) const {
  const LensSurface& s = surfaces_[k];
  const double zk = z_of(k), radius = s.radius, inv_radius = inv_radius_[k];
  const double half_aperture2 = half_aperture2_[k];
  double nx[N], ny[N], nz[N], cos_i[N];  // the live lanes' normals, and -(n . d)
  if (radius == 0.0) {
    for (int l = 0; l < N; ++l) {
      if (!r.live[l]) continue;
      const double t = (zk - r.oz[l]) / r.dz[l];
      r.live[l] = t > 0.0;
      if (!r.live[l]) continue;
      r.ox[l] += t * r.dx[l], r.oy[l] += t * r.dy[l], r.oz[l] += t * r.dz[l];
      nx[l] = 0.0, ny[l] = 0.0, nz[l] = r.dz[l] > 0.0 ? -1.0 : 1.0;
      cos_i[l] = -(nx[l] * r.dx[l] + ny[l] * r.dy[l] + nz[l] * r.dz[l]);
    }
  } else {
    const double centre_z = zk - radius, radius2 = radius * radius;
    const bool concave = radius < 0.0;
    for (int l = 0; l < N; ++l) {
      if (!r.live[l]) continue;
      const double ocx = r.ox[l], ocy = r.oy[l], ocz = r.oz[l] - centre_z;
      const double dx = r.dx[l], dy = r.dy[l], dz = r.dz[l];
      const double b = ocx * dx + ocy * dy + ocz * dz;
      const double disc = b * b - (ocx * ocx + ocy * ocy + ocz * ocz - radius2);
      // A miss (disc < 0, or NaN) stops the lane as it stops the scalar trace, whose root is
      // then never taken; the root of 0 in its place is not used.
      const double root = std::sqrt(disc >= 0.0 ? disc : 0.0);
      const double t = (dz > 0.0) == concave ? -b - root : -b + root;
      r.live[l] = disc >= 0.0 && t > 0.0;
      if (!r.live[l]) continue;
      r.ox[l] += t * dx, r.oy[l] += t * dy, r.oz[l] += t * dz;
      double x = (ocx + t * dx) * inv_radius, y = (ocy + t * dy) * inv_radius,
             z = (ocz + t * dz) * inv_radius;
      // Turned to face the ray. cross() then takes cos_i = -(n . d) of the turned normal, which
      // is this n . d where it was turned (a negated product, a sum of negated terms: negated
      // exactly, and n . d > 0 is no zero), else -(n . d).
      const double n_d = x * dx + y * dy + z * dz;
      const bool facing = n_d > 0.0;
      if (facing) x = -x, y = -y, z = -z;
      nx[l] = x, ny[l] = y, nz[l] = z;
      cos_i[l] = facing ? n_d : -n_d;
    }
  }
  for (int l = 0; l < N; ++l)
    r.live[l] = r.live[l] && !(r.ox[l] * r.ox[l] + r.oy[l] * r.oy[l] > half_aperture2);
  if (s.stop) return;
  for (int l = 0; l < N; ++l) {
    if (!r.live[l]) continue;
    const double dx = r.dx[l], dy = r.dy[l], dz = r.dz[l], eta = r.eta[l][k];
    const double sin2_t = eta * eta * std::max(0.0, 1.0 - cos_i[l] * cos_i[l]);
    r.live[l] = !(sin2_t >= 1.0);  // else total internal reflection
    if (!r.live[l]) continue;
    const double a = eta * cos_i[l] - std::sqrt(1.0 - sin2_t);
    r.dx[l] = eta * dx + a * nx[l], r.dy[l] = eta * dy + a * ny[l], r.dz[l] = eta * dz + a * nz[l];
  }
}

template <int N>
void RealLens::trace_span_lanes(RayLanes<N>& r, std::size_t first, std::size_t last) const {
  for (std::size_t k = last; k-- > first;) {
    cross_lanes(k, r);
    if (!r.any()) return;  // every lane stopped
  }
  r.normalise();
}

template <int N>
void RealLens::sample_lanes(const glm::dvec2* film, const glm::dvec2* u, const int* band,
                            Sample* out) const {
  RayLanes<N> r;
  double w[N], t[N], pass[N];
  for (int l = 0; l < N; ++l) {
    out[l] = Sample{};
    w[l] = 0.0, t[l] = 0.0, pass[l] = 1.0;
    r.live[l] = aim(film[l], u[l], out[l], w[l], t[l]);
    const glm::dvec3 o = out[l].ray.origin, d = out[l].ray.direction;
    r.ox[l] = o.x, r.oy[l] = o.y, r.oz[l] = o.z, r.dx[l] = d.x, r.dy[l] = d.y, r.dz[l] = d.z;
    const int b = band[l] < 0 || band[l] > 2 ? 0 : band[l] + 1;
    r.eta[l] = eta_from_film_[b].data();
  }
  const std::size_t count = surfaces_.size();
  if (!stop_aperture_) {
    trace_span_lanes(r, 0, count);
  } else {
    // trace_through_stop: to the stop, the shape's share where each lane crosses it, the rest.
    const std::size_t stop = static_cast<std::size_t>(stop_);
    trace_span_lanes(r, stop, count);
    for (int l = 0; l < N; ++l) {
      if (!r.live[l]) continue;
      pass[l] = stop_aperture_->pass(glm::vec2(static_cast<float>(r.ox[l] / stop_radius_),
                                               static_cast<float>(r.oy[l] / stop_radius_)));
      r.live[l] = pass[l] > 0.0;
    }
    if (r.any()) trace_span_lanes(r, 0, stop);
  }
  for (int l = 0; l < N; ++l) {
    out[l].ray.origin = {r.ox[l], r.oy[l], r.oz[l]};
    out[l].ray.direction = {r.dx[l], r.dy[l], r.dz[l]};
    if (r.live[l]) out[l].weight = finish(w[l], pass[l], t[l]);
  }
}

void RealLens::sample_n(std::size_t n, const glm::dvec2* film, const glm::dvec2* u,
                        const int* band, Sample* out) const {
  // Eight lanes keep the processor busier than four, and sixteen (more than it holds in flight)
  // less busy (bench/real_lens_bench.cpp); half a group for a rest, as the renderer's first
  // passes of 1, 2, 4 and 8 samples leave.
  constexpr int kHalf = kLanes / 2;
  std::size_t i = 0;
  for (; i + kLanes <= n; i += kLanes) sample_lanes<kLanes>(film + i, u + i, band + i, out + i);
  if (i + kHalf <= n) sample_lanes<kHalf>(film + i, u + i, band + i, out + i), i += kHalf;
  for (; i < n; ++i) out[i] = sample(film[i], u[i], band[i]);
}

double RealLens::field_angle(double height) const {
  // The chief ray: aim at the point x of the rear vertex plane whose ray crosses the stop's plane
  // on the axis, then follow it to the scene without clipping.
  const double z_rear = z_of(surfaces_.size() - 1);
  auto stop_x = [&](double x) {
    LensRay r{{height, 0.0, 0.0}, glm::normalize(glm::dvec3{x - height, 0.0, z_rear})};
    if (!trace_span(r, static_cast<std::size_t>(stop_) + 1, surfaces_.size(), true, -1, false))
      return std::numeric_limits<double>::quiet_NaN();
    const double t = (z_of(stop_) - r.origin.z) / r.direction.z;
    return r.origin.x + t * r.direction.x;
  };
  // Bracket the crossing on a scan of the rear plane (rays that miss a surface have none), the
  // bracket nearest the axis, then bisect.
  const double reach = 3.0 * surfaces_.back().aperture_diameter;
  constexpr int kScan = 600;
  double lo = 0.0, hi = 0.0, f_lo = 0.0;
  bool found = false;
  for (int i = 0; i < kScan && !found; ++i) {
    // From the axis outwards on both sides: 0, -d, +d, -2d, ...
    const double a = ((i + 1) / 2) * (reach / kScan) * (i % 2 ? -1.0 : 1.0);
    const double b = a + (i % 2 ? -1.0 : 1.0) * (reach / kScan);
    const double fa = stop_x(a), fb = stop_x(b);
    if (std::isfinite(fa) && std::isfinite(fb) && (fa <= 0.0) != (fb <= 0.0))
      lo = a, hi = b, f_lo = fa, found = true;
  }
  if (!found) return std::numeric_limits<double>::quiet_NaN();
  for (int i = 0; i < 100; ++i) {
    const double mid = 0.5 * (lo + hi);
    const double fm = stop_x(mid);
    if (!std::isfinite(fm)) break;
    if ((fm <= 0.0) == (f_lo <= 0.0)) lo = mid, f_lo = fm;
    else hi = mid;
  }
  const double x1 = 0.5 * (lo + hi);
  LensRay r{{height, 0.0, 0.0}, glm::normalize(glm::dvec3{x1 - height, 0.0, z_rear})};
  if (!trace_from_film(r, -1, false))
    return std::numeric_limits<double>::quiet_NaN();
  return std::atan2(std::hypot(r.direction.x, r.direction.y), r.direction.z);
}

bool RealLens::dispersive() const {
  return std::any_of(surfaces_.begin(), surfaces_.end(),
                     [](const LensSurface& s) { return s.abbe > 0.0 && s.ior != 1.0; });
}

bool RealLens::passes_rims(LensRay ray) const {
  const std::size_t stop = static_cast<std::size_t>(stop_);
  return trace_span(ray, stop + 1, surfaces_.size(), true, -1, true) &&
         cross(stop, ray.origin, ray.direction, 1.0, false) &&
         trace_span(ray, 0, stop, true, -1, true);
}

std::optional<glm::dvec2> RealLens::stop_point(LensRay ray) const {
  const std::size_t stop = static_cast<std::size_t>(stop_);
  if (!trace_span(ray, stop + 1, surfaces_.size(), true, -1, false) ||
      !cross(stop, ray.origin, ray.direction, 1.0, false))
    return std::nullopt;
  return glm::dvec2(ray.origin) / stop_radius_;
}

glm::dvec2 Sensor::film_size(int width_px, int height_px) const {
  const double aspect = static_cast<double>(width_px) / height_px;
  switch (fit) {
    case SensorFit::Horizontal: return {width, width / aspect};
    case SensorFit::Vertical: return {height * aspect, height};
    case SensorFit::Inside: break;
  }
  return aspect >= width / height ? glm::dvec2{width, width / aspect}
                                  : glm::dvec2{height * aspect, height};
}

void Sensor::validate() const {
  if (!(width > 0.0 && width <= 1.0 && height > 0.0 && height <= 1.0))
    throw Error("the sensor's width and height must be in (0, 1] m (36 x 24 mm is 0.036,0.024)");
}

const char* sensor_fit_name(SensorFit fit) {
  switch (fit) {
    case SensorFit::Horizontal: return "horizontal";
    case SensorFit::Vertical: return "vertical";
    case SensorFit::Inside: break;
  }
  return "inside";
}

SensorFit parse_sensor_fit(const std::string& name) {
  for (SensorFit f : {SensorFit::Inside, SensorFit::Horizontal, SensorFit::Vertical})
    if (name == sensor_fit_name(f)) return f;
  throw Error("sensor fit '" + name.substr(0, 32) + "': expected inside, horizontal or vertical");
}

ThinLens MountedLens::equivalent() const {
  const CardinalPoints& c = lens->cardinal();
  // Infinity stays finite for the thin-lens law (the circle of confusion differs by less than
  // f / 1e7 of the aperture).
  const double focus = std::min(lens->focus_distance(), 1e7) - c.front_principal_z;
  ThinLens thin(c.focal_length, lens->fstop(), focus);
  thin.aperture = lens->stop_shape();
  thin.aperture.rims = rims_of(lens->rims(), thin, !lens->exposure_follows_lens());
  return thin;
}

double MountedLens::yfov() const { return field_of_view().y; }

glm::dvec2 MountedLens::field_of_view() const {
  const double v = equivalent().film_distance();
  return {2.0 * std::atan(0.5 * film_size.x / v), 2.0 * std::atan(0.5 * film_size.y / v)};
}

double MountedLens::corner_distortion() const {
  const double r = 0.5 * std::hypot(film_size.x, film_size.y);
  const double theta = lens->field_angle(r);
  if (!(theta < 1.5)) return std::numeric_limits<double>::infinity();  // ~86 degrees and beyond
  return std::abs(equivalent().film_distance() * std::tan(theta) / r - 1.0);
}

std::shared_ptr<const LensSystem> read_lens_file(const std::string& path) {
  static core::SharedCache<LensSystem> read;
  auto load = [&] { return std::make_shared<const LensSystem>(LensSystem::read(path)); };
  if (const auto key = core::file_version_key(path)) return read.get(*key, load);
  // No such file: a shipped lens by its name, else LensSystem::read's one-line error with the
  // names that would have been found.
  if (const ShippedLens* shipped = find_shipped_lens(path))
    return read.get("shipped\n" + std::string(shipped->name), [&] {
      return std::make_shared<const LensSystem>(
          LensSystem::parse(std::string(shipped->table), std::string(shipped->name) + ".lens"));
    });
  try {
    return load();
  } catch (const Error& e) {
    throw Error(std::string(e.what()) + " (nor is it a shipped lens: " + shipped_lens_names() + ")");
  }
}

MountedLens mount_lens(const std::shared_ptr<const LensSystem>& system, const std::string& source,
                       double fstop, double focus_distance, const Sensor& sensor, int width,
                       int height, bool exposure_follows_lens, const ApertureShape& shape) {
  sensor.validate();
  if (width < 1 || height < 1) throw Error("the image must have at least one pixel");
  ApertureShape stop = shape;
  stop.rims = {};  // an equivalent's (a lens mounted again): the lens's own are RealLens::rims
  check_stop_shape(stop);  // before the kept lenses, whose keys hold only what a stop takes
  MountedLens m;
  m.film_size = sensor.film_size(width, height);
  m.source = source;
  RealLensSettings settings;
  settings.fstop = fstop;
  settings.focus_distance = focus_distance;
  settings.film_radius = 0.5 * std::hypot(m.film_size.x, m.film_size.y) * (1.0 + 1e-9);
  settings.exposure_follows_lens = exposure_follows_lens;
  settings.stop_shape = stop;
  // Keyed by the prescription's numbers and the settings (an aperture image by its version).
  static core::SharedCache<RealLens> mounted;
  std::ostringstream key;
  key.precision(17);
  for (const LensSurface& s : system->surfaces())
    key << s.radius << ' ' << s.thickness << ' ' << s.ior << ' ' << s.aperture_diameter << ' '
        << s.abbe << ' ' << s.stop << '\n';
  key << fstop << ' ' << focus_distance << ' ' << settings.film_radius << ' '
      << exposure_follows_lens << '\n' << stop.blades << ' ' << stop.rotation_deg << ' '
      << stop.roundness << ' ' << stop.anamorphic_ratio << ' '
      << aperture_profile_name(stop.profile) << ' ' << stop.profile_strength << ' '
      << (stop.image.empty() ? "" : core::file_version_key(stop.image).value_or(stop.image));
  m.lens = mounted.get(key.str(), [&] { return std::make_shared<const RealLens>(*system, settings); });
  return m;
}

}  // namespace dofcache::lens
