#pragma once
// A real lens's own optical vignetting, fitted so that its thin-lens equivalent draws it: the
// preview's cat's eyes that change across the frame, as the traced lens's do.
//
// Off the axis, the rims of the elements in front of the stop clip one side of a film point's
// bundle and those behind it the other. Seen at the stop, each side's clipping is close to a disc
// whose centre moves out with the film point, which is what a circular stop in front of a thin
// lens (ApertureShape's vignetting stop) or behind it does. So two discs are fitted in the stop's
// units (its radius 1): the film point f (metres, lens space) sees the stop through the front
// disc of centre front.slope * f and radius front.radius, and the rear one likewise. Boundary
// points of the traced bundle (rays from the film point bisected to where a rim stops them, then
// followed to the stop's plane) give each side's circle per distance from the centre; the
// radius is their mean and the slope the least-squares line of where each edge crosses the film
// point's radial axis.
#include "dofcache/lens/aperture.h"
#include "dofcache/lens/thin_lens.h"

namespace dofcache::lens {

class RealLens;

struct RimDisc {
  double slope = 0.0;   // the centre's offset per metre of the film point's (stop units / m)
  double radius = 0.0;  // stop units; 0: no such rim clips within the film
  bool present() const { return radius > 0.0; }
};

struct RimModel {
  RimDisc front;  // clips the side away from the film point (slope > 0)
  RimDisc rear;   // clips the side towards it (slope < 0)
};

// The two discs for film points up to `film_radius` (metres) from the centre. A side no rim
// clips inside the stop stays absent.
RimModel fit_rims(const RealLens& lens, double film_radius);

// The model as the stops of `thin` (the lens's equivalent, its aperture the stop): a front stop
// of radius R at distance d and a rear one of radius R' at distance d' behind the lens, placed so
// that a point at the focus distance P, whose film point is f = -V s (s its pinhole slopes, V
// the film distance), sees the fitted discs (camera.h's BokehSpot): d / ((1 - d / P) r) =
// slope V and R = radius r (1 - d / P), and d' / ((1 - d' / V) r) = -slope V and
// R' = radius r (1 - d' / V), r the aperture's radius. `normalised`: the image is divided by
// what the rims pass (the traced lens's exposure does not follow it).
LensRims rims_of(const RimModel& model, const ThinLens& thin, bool normalised);

}  // namespace dofcache::lens
