// The GGX lobe's sampling against its density and its integral, both computed here by quadrature
// over the hemisphere of reflected directions (independent of the sampler).
#include "dofcache/render/ggx.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include <glm/geometric.hpp>

namespace dofcache::render {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Quadrature over the upper hemisphere of directions wi = (sqrt(1 - mu^2) cos phi, ..., mu),
// d omega = d mu d phi, midpoints of an n x 4n grid: calls f(wi, d omega).
template <class F>
void hemisphere(int n, const F& f) {
  const double dmu = 1.0 / n, dphi = 2.0 * kPi / (4 * n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < 4 * n; ++j) {
      const double mu = (i + 0.5) * dmu, phi = (j + 0.5) * dphi, s = std::sqrt(1.0 - mu * mu);
      f(glm::vec3(static_cast<float>(s * std::cos(phi)), static_cast<float>(s * std::sin(phi)),
                  static_cast<float>(mu)),
        dmu * dphi);
    }
}

// The density of reflecting v into wi (ggx.h), from the half-vector.
double pdf(glm::vec3 v, glm::vec3 wi, float alpha) {
  const glm::vec3 h = glm::normalize(v + wi);
  return ggx_vndf_pdf(h.z, v.z, alpha);
}

TEST(Ggx, DistributionIsNormalised) {
  // The projected microfacet area is the macro surface's: the integral of D(h) (n.h) is 1.
  for (float alpha : {0.1f, 0.3f, 1.0f}) {
    double sum = 0;
    hemisphere(2000, [&](glm::vec3 h, double dw) { sum += ggx_d(h.z, alpha) * h.z * dw; });
    EXPECT_NEAR(sum, 1.0, 2e-3) << "alpha " << alpha;
  }
  // By hand: D(1) = 1 / (pi alpha^2); smith_g1 is 1 at normal incidence, and for alpha = 1
  // G1(mu) = 2 mu / (mu + 1).
  EXPECT_NEAR(ggx_d(1.0f, 0.5f), 1.0 / (kPi * 0.25), 1e-6);
  EXPECT_NEAR(smith_g1(1.0f, 0.3f), 1.0, 1e-6);
  EXPECT_NEAR(smith_g1(0.2f, 1.0f), 0.4 / 1.2, 1e-6);
}

// Directions reflected about sampled visible normals fall in proportion to ggx_vndf_pdf, cell by
// cell of a 6 x 8 (mu, phi) grid, and the renderer's weight F G1(n.l) (with F = 1) averages to
// the lobe's directional albedo, the integral of D G1(n.v) G1(n.l) / (4 n.v) over the hemisphere.
TEST(Ggx, VisibleNormalSamplesFollowTheirDensityAndWeighToTheAlbedo) {
  for (float alpha : {0.25f, 1.0f})
    for (float n_v : {0.95f, 0.3f, 0.08f}) {
      const glm::vec3 v(std::sqrt(1.0f - n_v * n_v), 0.0f, n_v);
      const int rows = 6, cols = 8;
      std::vector<double> expected(rows * cols, 0.0), counted(rows * cols, 0.0);
      auto cell = [&](glm::vec3 wi) {
        const int r = std::min(rows - 1, static_cast<int>(wi.z * rows));
        double phi = std::atan2(wi.y, wi.x);
        if (phi < 0) phi += 2 * kPi;
        return r * cols + std::min(cols - 1, static_cast<int>(phi / (2 * kPi) * cols));
      };
      double albedo = 0.0, upper = 0.0;
      hemisphere(600, [&](glm::vec3 wi, double dw) {
        const double p = pdf(v, wi, alpha) * dw;
        expected[cell(wi)] += p;
        upper += p;
        albedo += p * smith_g1(wi.z, alpha);  // f cos = pdf G1(n.l)
      });
      const int n = 400000;
      double weight_sum = 0.0;
      int below = 0;
      for (int k = 0; k < n; ++k) {
        // A Fibonacci lattice: stratified, and independent of the sampler's own arithmetic.
        const glm::vec2 u((k + 0.5f) / n, std::fmod(k * 0.61803398875f, 1.0f));
        const glm::vec3 h = sample_ggx_visible_normal(v, alpha, u);
        const glm::vec3 wi = 2.0f * glm::dot(v, h) * h - v;
        if (wi.z <= 0.0f) {
          ++below;
          continue;
        }
        weight_sum += smith_g1(wi.z, alpha);
        counted[cell(wi)] += 1.0 / n;
      }
      SCOPED_TRACE(::testing::Message() << "alpha " << alpha << ", n.v " << n_v);
      for (int i = 0; i < rows * cols; ++i)
        EXPECT_NEAR(counted[i], expected[i], 0.004 + 0.03 * expected[i]) << "cell " << i;
      EXPECT_NEAR(static_cast<double>(below) / n, 1.0 - upper, 0.005);
      EXPECT_NEAR(weight_sum / n, albedo, 0.005 + 0.01 * albedo);
      EXPECT_LE(albedo, 1.0);
    }
}

}  // namespace
}  // namespace dofcache::render
