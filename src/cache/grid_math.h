#pragma once
// Power-of-two cell arithmetic shared by the octree and vdb backends. Cells of level e have edge
// 2^e and are aligned to multiples of it, so both backends partition space identically and every
// bound below is an exact double.
#include <cmath>

namespace dofcache::cache {

// Smallest e with 2^e >= x, for x > 0.
inline int ceil_log2(double x) {
  int e;
  double m = std::frexp(x, &e);  // x = m 2^e, m in [0.5, 1)
  return m == 0.5 ? e - 1 : e;
}

// Structures bound sample spheres conservatively: a sample is filed wherever a point within this
// factor of its radius could be, so that no rounding in the float acceptance test (which requires
// ||p - p_i|| < r_i) can accept a sample the structure did not offer.
constexpr double kRadiusPad = 1.0 + 1e-5;

}  // namespace dofcache::cache
