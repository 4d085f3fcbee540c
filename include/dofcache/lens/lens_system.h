#pragma once
// A real lens from its prescription (the lens-prescription issue, first part): the table of
// spherical surfaces pbrt-v4's realistic camera reads, and its paraxial optics.
//
// Table: one surface per line, front (object side) first, whitespace-separated numbers in
// millimetres: curvature radius (positive: centre of curvature behind the surface, towards the
// film; 0: flat, and the aperture stop when its index is 0), thickness (the axial distance to the
// next surface; the last one's, to the film), the index of refraction of what follows the surface
// (1: air; 0 is read as air, as on pbrt's stop rows) and the clear aperture's diameter. An
// optional fifth column, the glass's Abbe number, is our extension (0 or absent: no dispersion).
// '#' starts a comment; blank lines are skipped.
//
// Paraxial optics by the y-nu trace: a ray at height y with angle u meets surface k (curvature
// c = 1 / R) and leaves with n' u' = n u - y c (n' - n), then travels y += t u'. A ray entering
// parallel to the axis at height h leaves with angle u: the effective focal length is -h / u and
// the back focal distance (last surface to the focus) -y / u.
#include <string>
#include <vector>

namespace dofcache::lens {

struct LensSurface {
  double radius = 0;             // metres; 0: flat
  double thickness = 0;          // metres to the next surface (the last: to the film)
  double ior = 1;                // of the medium after the surface
  double aperture_diameter = 0;  // metres
  double abbe = 0;               // of that medium; 0: none
  bool stop = false;             // the aperture stop (radius 0 and index 0 in the table)
};

class LensSystem {
 public:
  // Throws dofcache::Error, one line naming `source` and the line: not a number, a line of the
  // wrong width, a non-positive aperture or index, a negative thickness, no surfaces, more than
  // one stop, a surface with a radius smaller than half its aperture, absurd sizes.
  static LensSystem parse(const std::string& text, const std::string& source);
  // parse() of a file; an unreadable one is a one-line error too.
  static LensSystem read(const std::string& path);

  const std::vector<LensSurface>& surfaces() const { return surfaces_; }
  int stop_index() const { return stop_; }  // -1: no stop row
  // Paraxial (y-nu), metres. Throws dofcache::Error for an afocal system.
  double effective_focal_length() const;
  double back_focal_distance() const;

 private:
  std::vector<LensSurface> surfaces_;
  int stop_ = -1;
};

}  // namespace dofcache::lens
