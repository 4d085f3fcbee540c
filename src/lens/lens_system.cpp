#include "dofcache/lens/lens_system.h"

#include <cmath>
#include <fstream>
#include <sstream>

#include "dofcache/core/error.h"

namespace dofcache::lens {
namespace {

constexpr double kMm = 1e-3;
constexpr std::size_t kMaxSurfaces = 256;

struct Paraxial {
  double h, y, u;  // the entering height; at the film side of the last surface
};

// A ray parallel to the axis through every surface (y-nu). Throws for an afocal system.
Paraxial trace_parallel(const std::vector<LensSurface>& s) {
  const double h = 1e-3;
  double y = h, u = 0.0, n = 1.0;
  for (std::size_t k = 0; k < s.size(); ++k) {
    const double c = s[k].radius != 0.0 ? 1.0 / s[k].radius : 0.0;
    const double n2 = s[k].ior;
    u = (n * u - y * c * (n2 - n)) / n2;
    n = n2;
    if (k + 1 < s.size()) y += s[k].thickness * u;  // the last thickness is the film's
  }
  if (!(std::abs(u) > 1e-15)) throw Error("the lens is afocal: it has no focal length");
  return {h, y, u};
}

}  // namespace

LensSystem LensSystem::parse(const std::string& text, const std::string& source) {
  LensSystem system;
  std::istringstream in(text);
  std::string line;
  int number = 0;
  auto fail = [&](const std::string& what) -> void {
    throw Error("lens file " + source + ", line " + std::to_string(number) + ": " + what);
  };
  while (std::getline(in, line)) {
    ++number;
    if (const auto hash = line.find('#'); hash != std::string::npos) line.resize(hash);
    std::istringstream fields(line);
    std::vector<double> v;
    std::string field;
    while (fields >> field) {
      char* end = nullptr;
      const double x = std::strtod(field.c_str(), &end);
      if (end == field.c_str() || *end != '\0' || !std::isfinite(x))
        fail("'" + field.substr(0, 32) + "' is not a number");
      v.push_back(x);
    }
    if (v.empty()) continue;
    if (v.size() != 4 && v.size() != 5)
      fail("expected 4 or 5 numbers (radius, thickness, index, aperture[, Abbe number]), got " +
           std::to_string(v.size()));
    if (system.surfaces_.size() >= kMaxSurfaces)
      fail("more than " + std::to_string(kMaxSurfaces) + " surfaces");
    LensSurface s;
    s.radius = v[0] * kMm;
    s.thickness = v[1] * kMm;
    s.stop = v[0] == 0.0 && v[2] == 0.0;
    s.ior = v[2] == 0.0 ? 1.0 : v[2];
    s.aperture_diameter = v[3] * kMm;
    s.abbe = v.size() == 5 ? v[4] : 0.0;
    if (std::abs(v[0]) > 1e7 || v[1] > 1e6 || v[3] > 1e5)
      fail("a size beyond 10 km");
    if (s.thickness < 0.0) fail("a negative thickness");
    if (!(s.ior >= 1.0 && s.ior < 5.0)) fail("an index of refraction outside [1, 5)");
    if (!(s.aperture_diameter > 0.0)) fail("the aperture diameter must be positive");
    if (s.abbe < 0.0) fail("a negative Abbe number");
    if (s.radius != 0.0 && std::abs(s.radius) < 0.5 * s.aperture_diameter)
      fail("a curvature radius smaller than half the surface's aperture");
    if (s.stop) {
      if (system.stop_ >= 0) fail("a second aperture stop (radius 0 and index 0)");
      system.stop_ = static_cast<int>(system.surfaces_.size());
    }
    system.surfaces_.push_back(s);
  }
  if (system.surfaces_.empty()) throw Error("lens file " + source + ": no surfaces");
  return system;
}

LensSystem LensSystem::read(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw Error("cannot read the lens file " + path);
  std::ostringstream text;
  text << f.rdbuf();
  return parse(text.str(), path);
}

double LensSystem::effective_focal_length() const {
  const Paraxial p = trace_parallel(surfaces_);
  return -p.h / p.u;
}

double LensSystem::back_focal_distance() const {
  const Paraxial p = trace_parallel(surfaces_);
  return -p.y / p.u;
}

}  // namespace dofcache::lens
