#include "dofcache/lens/lens_rims.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <vector>

#include <glm/geometric.hpp>

#include "dofcache/lens/real_lens.h"

namespace dofcache::lens {
namespace {

constexpr int kHeights = 16;  // film distances from the centre fitted
// Rows of the bundle (aim units, about the stop's) whose edges are found.
constexpr double kRows[] = {0.0, -0.3, 0.3, -0.6, 0.6};
// A side whose edge lies beyond this (stop units) on the film point's axis clips nothing visible.
constexpr double kReach = 1.05;

// One side's boundary at one film distance: the circle through its edge points.
struct SideCircle {
  double height = 0, centre = 0, radius = 0, edge = 0;  // edge: where it crosses y = 0
};

// The bundle of film point (h, 0): rays aimed at points a R_xp of the exit pupil's plane.
class Bundle {
 public:
  Bundle(const RealLens& lens, double h) : lens_(lens), h_(h) {
    const CardinalPoints& c = lens.cardinal();
    z_ = c.exit_pupil_z;
    scale_ = 0.5 * c.exit_pupil_diameter;
  }
  LensRay ray(double ax, double ay) const {
    return {{h_, 0.0, 0.0},
            glm::normalize(glm::dvec3{ax * scale_ - h_, ay * scale_, z_})};
  }
  bool passes(double ax, double ay) const { return lens_.passes_rims(ray(ax, ay)); }
  // From `inside` (passing) outwards along x on row ay, the last passing aim before `limit`.
  std::optional<double> edge(double inside, double limit, double ay) const {
    constexpr int kSteps = 64;
    const double step = (limit - inside) / kSteps;
    double a = inside;
    for (int i = 1; i <= kSteps; ++i) {
      double b = inside + i * step;
      if (!passes(b, ay)) {
        for (int k = 0; k < 40; ++k) {
          const double m = 0.5 * (a + b);
          (passes(m, ay) ? a : b) = m;
        }
        return a;
      }
      a = b;
    }
    return std::nullopt;  // open up to the limit
  }

 private:
  const RealLens& lens_;
  double h_, z_, scale_;
};

// The circle x^2 + y^2 + D x + F = 0 (centre on the axis, as the bundle is symmetric about it)
// nearest the points in least squares (Kasa's algebraic fit).
std::optional<SideCircle> fit_circle(const std::vector<glm::dvec2>& p) {
  if (p.size() < 3) return std::nullopt;
  double sxx = 0, sx = 0, n = 0, sxz = 0, sz = 0;
  for (const glm::dvec2& q : p) {
    const double z = q.x * q.x + q.y * q.y;
    sxx += q.x * q.x, sx += q.x, n += 1, sxz += q.x * z, sz += z;
  }
  const double det = sxx * n - sx * sx;
  if (!(std::abs(det) > 1e-12)) return std::nullopt;
  const double d = (-sxz * n + sz * sx) / det, f = (-sz - d * sx) / n;
  const double c = -0.5 * d, r2 = c * c - f;
  if (!(r2 > 0.0)) return std::nullopt;
  SideCircle s;
  s.centre = c, s.radius = std::sqrt(r2);
  return s;
}

// The stop's plane of each aim point, kept where the ray reaches it.
std::vector<glm::dvec2> at_stop(const RealLens& lens, const Bundle& b,
                                const std::vector<glm::dvec2>& aims) {
  std::vector<glm::dvec2> out;
  for (const glm::dvec2& a : aims)
    if (const auto s = lens.stop_point(b.ray(a.x, a.y))) out.push_back(*s);
  return out;
}

// The least-squares disc of one side: radius the circles' mean, slope through their edges.
RimDisc model_side(const std::vector<SideCircle>& circles, double sign, double film_radius) {
  RimDisc d;
  if (circles.size() < 2) return d;
  double radius = 0;
  for (const SideCircle& c : circles) radius += c.radius;
  radius /= static_cast<double>(circles.size());
  // centre = edge - sign radius = slope h.
  double shh = 0, sch = 0;
  for (const SideCircle& c : circles) {
    shh += c.height * c.height;
    sch += (c.edge - sign * radius) * c.height;
  }
  const double slope = sch / shh;
  // A front rim's disc moves with the film point, a rear one's against it.
  if (!(sign < 0.0 ? slope > 0.0 : slope < 0.0)) return d;
  // A disc that holds the whole stop out to the film's corner cuts nothing (a sliver of under
  // a hundredth of the stop's radius is nothing either).
  if (std::abs(slope) * film_radius + 1.0 <= radius + 0.01) return d;
  d.slope = slope, d.radius = radius;
  return d;
}

}  // namespace

RimModel fit_rims(const RealLens& lens, double film_radius) {
  std::vector<SideCircle> sides[2];  // [0]: the side away from the film point (-x), [1]: towards
  for (int i = 1; i <= kHeights; ++i) {
    const double h = film_radius * i / kHeights;
    const Bundle bundle(lens, h);
    // The chief ray's aim (where the bundle is widest), from the stop's centre on row 0: the
    // passing interval nearest the aim 0 on a coarse scan.
    double inside = 0.0;
    bool found = false;
    for (int k = 0; k <= 80 && !found; ++k) {
      const double a = (k % 2 ? -1.0 : 1.0) * 0.05 * ((k + 1) / 2);
      if (bundle.passes(a, 0.0)) inside = a, found = true;
    }
    if (!found) continue;
    for (int side = 0; side < 2; ++side) {
      const double sign = side == 0 ? -1.0 : 1.0;
      std::vector<glm::dvec2> aims;
      for (double row : kRows) {
        if (!bundle.passes(inside, row)) continue;
        if (const auto e = bundle.edge(inside, inside + sign * 4.0, row))
          aims.push_back({*e, row});
      }
      const std::vector<glm::dvec2> points = at_stop(lens, bundle, aims);
      if (points.empty() || !(std::abs(points.front().y) < 1e-9) || points.front().x * sign < 0.0)
        continue;  // no edge on the axis row, or one past the centre
      if (points.front().x * sign > kReach) continue;  // clips nothing the stop passes
      std::optional<SideCircle> c = fit_circle(points);
      if (!c) continue;
      c->height = h;
      c->edge = points.front().x;
      sides[side].push_back(*c);
    }
  }
  RimModel m;
  m.front = model_side(sides[0], -1.0, film_radius);
  m.rear = model_side(sides[1], 1.0, film_radius);
  return m;
}

LensRims rims_of(const RimModel& model, const ThinLens& thin, bool normalised) {
  LensRims rims;
  const double r = thin.aperture_radius(), v = thin.film_distance(), p = thin.focus_distance;
  if (model.front.present()) {
    const double k = model.front.slope * v * r;  // d / (1 - d / P)
    const double d = k / (1.0 + k / p);
    rims.front = {model.front.radius * r * (1.0 - d / p), d};
  }
  if (model.rear.present()) {
    const double k = -model.rear.slope * v * r;  // d' / (1 - d' / V)
    const double d = k / (1.0 + k / v);
    rims.rear = {model.rear.radius * r * (1.0 - d / v), d};
  }
  rims.normalised = normalised && rims.any();
  return rims;
}

}  // namespace dofcache::lens
