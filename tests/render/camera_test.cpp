// The thin-lens camera against the paper's geometry (eqs. 2.4-2.6).
#include "dofcache/render/camera.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>

namespace dofcache::render {
namespace {

constexpr float kYfov = 0.6f;

ThinLensCamera make(double focal, double fstop, double focus) {
  return ThinLensCamera(glm::mat4(1.0f), kYfov, lens::ThinLens{focal, fstop, focus}, 200, 100);
}

glm::vec3 at_depth(const ThinLensCamera& cam, const scene::Ray& r, float depth) {
  return r.origin + r.direction * cam.t_at_depth(r, depth);
}

TEST(ThinLensCamera, PinholeThroughCentreLooksDownMinusZ) {
  ThinLensCamera cam = make(0.05, 2.0, 2.0);
  scene::Ray r = cam.pinhole_ray({100.0f, 50.0f});
  EXPECT_NEAR(r.direction.z, -1.0f, 1e-6f);
  // Top edge of the film sees yfov/2 above the axis.
  scene::Ray top = cam.pinhole_ray({100.0f, 0.0f});
  EXPECT_NEAR(std::atan2(top.direction.y, -top.direction.z), kYfov / 2, 1e-5f);
}

TEST(ThinLensCamera, AllLensRaysOfAFilmPointMeetOnTheFocalPlane) {
  ThinLensCamera cam = make(0.1, 1.4, 3.0);
  glm::vec2 film(37.3f, 81.9f);
  glm::vec3 expected = at_depth(cam, cam.pinhole_ray(film), 3.0f);
  for (glm::vec2 u : {glm::vec2(0.1f, 0.2f), glm::vec2(0.9f, 0.5f), glm::vec2(0.5f, 0.99f)}) {
    glm::vec3 p = at_depth(cam, cam.generate_ray(film, u), 3.0f);
    EXPECT_NEAR(glm::distance(p, expected), 0.0f, 1e-5f);
  }
}

TEST(ThinLensCamera, RayConeRadiusAtDepthIsEq2_5) {
  // Rays from the lens rim and the lens centre, for one film point, are r(D) apart at depth D.
  const double F = 0.1, n = 2.0, P = 2.0;
  ThinLensCamera cam = make(F, n, P);
  glm::vec2 film(100.0f, 50.0f);
  for (float depth : {1.0f, 1.5f, 3.0f, 6.0f}) {
    glm::vec3 centre = at_depth(cam, cam.generate_ray(film, {0.5f, 0.5f}), depth);
    glm::vec3 rim = at_depth(cam, cam.generate_ray(film, {1.0f, 0.5f}), depth);  // disk (1, 0)
    // Hand value for D = 3: 0.5 * (0.1/2) * |3 - 2| / 2 = 0.0125 m.
    if (depth == 3.0f) {
      EXPECT_NEAR(glm::distance(centre, rim), 0.0125f, 1e-6f);
    }
    EXPECT_NEAR(glm::distance(centre, rim), lens::cone_radius(F, n, P, depth), 1e-6f);
  }
}

TEST(ThinLensCamera, NearPlaneParameter) {
  ThinLensCamera cam = make(0.05, 2.0, 2.0);
  scene::Ray r = cam.pinhole_ray({0.0f, 0.0f});  // oblique corner ray
  float t = cam.t_at_depth(r, 1.5f);
  EXPECT_NEAR(cam.depth(r.origin + t * r.direction), 1.5f, 1e-5f);
}

TEST(ThinLensCamera, FilmToWorldMapsEachFilmPointAndDepthOntoItsPinholeRay) {
  const ThinLensCamera cam(
      glm::rotate(glm::translate(glm::mat4(1.0f), glm::vec3(1, 2, 3)), 0.4f, glm::vec3(0, 1, 0)),
      0.7f, lens::ThinLens{}, 64, 40);
  const glm::mat4 m = cam.film_to_world();
  for (glm::vec2 film : {glm::vec2(0.0f, 0.0f), glm::vec2(31.5f, 20.25f), glm::vec2(64, 40)})
    for (float z : {0.5f, 3.0f}) {
      const scene::Ray ray = cam.pinhole_ray(film);
      const glm::vec3 expected = ray.origin + ray.direction * (z / glm::dot(ray.direction,
                                                                            cam.forward()));
      const glm::vec4 got = m * glm::vec4(film.x * z, film.y * z, z, 1.0f);
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], expected[c], 1e-5f);
      EXPECT_FLOAT_EQ(got.w, 1.0f);
    }
}

// A shifted film moves the view by shift image heights without turning the camera: the centre
// pixel looks along forward + 2 tan(yfov / 2) (shift_x right + shift_y up), and film_to_world
// follows the shifted film.
TEST(ThinLensCamera, ShiftMovesTheViewWithoutTurningIt) {
  lens::ThinLens lens;
  lens.aperture.shift_x = 0.25;
  lens.aperture.shift_y = -0.1;
  const float yfov = 0.7f;
  const ThinLensCamera cam(glm::mat4(1.0f), yfov, lens, 64, 40);
  const glm::vec3 d = cam.pinhole_ray({32.0f, 20.0f}).direction;
  const float t = std::tan(0.5f * yfov);
  const glm::vec3 expected = glm::normalize(glm::vec3(2.0f * t * 0.25f, 2.0f * t * -0.1f, -1.0f));
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(d[c], expected[c], 1e-6f);
  EXPECT_NEAR(glm::dot(cam.forward(), glm::vec3(0, 0, -1)), 1.0f, 1e-6f);  // not turned
  const glm::mat4 m = cam.film_to_world();
  for (glm::vec2 film : {glm::vec2(0.0f, 0.0f), glm::vec2(50.0f, 7.5f)}) {
    const scene::Ray ray = cam.pinhole_ray(film);
    const glm::vec4 got = m * glm::vec4(film.x * 2.0f, film.y * 2.0f, 2.0f, 1.0f);
    const glm::vec3 want = ray.origin + ray.direction * (2.0f / glm::dot(ray.direction, cam.forward()));
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], want[c], 1e-5f);
  }
}

// bokeh(): every lens ray that meets a point at depth D leaves the film where the bokeh's centre
// and scale put its aperture point, and the stop passes exactly the rays inside its disc. The
// point and its pinhole image come from the traced ray and film_to_world, not from bokeh().
void expect_bokeh_matches_lens_rays(const lens::ThinLens& lens, int band, float tolerance_px) {
  const ThinLensCamera cam(glm::mat4(1.0f), kYfov, lens, 200, 100);
  const glm::mat4 to_film = glm::inverse(cam.film_to_world());
  const double r = lens.aperture_radius();
  int checked = 0, stopped = 0;
  for (float depth : {0.8f, 1.7f, 9.0f}) {
    for (int i = 0; i < 40; ++i) {
      const glm::vec2 film(5.0f + 4.7f * i, 3.0f + 2.3f * ((7 * i) % 41));
      const glm::vec2 u((i * 0.618034f) - std::floor(i * 0.618034f), (i + 0.5f) / 40.0f);
      const LensSample s = cam.lens_ray(film, u, band);
      const glm::vec3 x = at_depth(cam, s.ray, depth);
      const glm::vec4 h = to_film * glm::vec4(x, 1.0f);
      const glm::vec2 pinhole(h.x / h.z, h.y / h.z);
      const glm::vec2 a(s.ray.origin.x / static_cast<float>(r), s.ray.origin.y / static_cast<float>(r));
      const BokehSpot b = cam.bokeh(pinhole, depth, band);
      const glm::vec2 o = b.scale * a / (1.0f + glm::dot(a, b.tilt));
      const glm::vec2 predicted = b.centre + glm::vec2(o.x, -o.y);
      EXPECT_LT(glm::distance(predicted, film), tolerance_px) << "depth " << depth << " ray " << i;
      const float off = glm::distance(a, b.stops[0].centre) - b.stops[0].radius;
      if (std::abs(off) > 1e-3f) {  // not on the stop's rim
        EXPECT_EQ(s.weight == 0.0f, off > 0.0f) << "depth " << depth << " ray " << i;
        stopped += s.weight == 0.0f;
      }
      ++checked;
    }
  }
  EXPECT_EQ(checked, 120);
  if (lens.aperture.vignetting()) {
    EXPECT_GT(stopped, 5);  // the stop was exercised
  }
}

TEST(ThinLensCamera, BokehPutsEveryLensRayWhereItMeetsItsPoint) {
  const lens::ThinLens plain{0.1, 1.4, 2.5};
  expect_bokeh_matches_lens_rays(plain, -1, 2e-3f);
  lens::ThinLens shaped = plain;
  shaped.aperture.blades = 6;
  shaped.aperture.anamorphic_ratio = 1.5;
  shaped.aperture.shift_x = 0.2;
  shaped.aperture.shift_y = -0.1;
  shaped.aperture.stop = {0.01, 0.04};
  expect_bokeh_matches_lens_rays(shaped, -1, 2e-3f);
  shaped.aperture.axial_ca = 0.3;
  shaped.aperture.lateral_ca = 0.05;
  for (int band : {0, 1, 2}) expect_bokeh_matches_lens_rays(shaped, band, 2e-3f);
}

TEST(ThinLensCamera, BokehFollowsATiltedPlaneOfFocus) {
  // Tilted, the rays of one film point converge where their own direction meets the plane, which
  // varies across the bokeh: the projective term gives each ray its own. (Focused at 1.5 m the
  // plane meets every pixel's ray ahead of the lens.)
  lens::ThinLens tilted{0.1, 1.4, 1.5};
  tilted.aperture.tilt_x_deg = 4.0;
  tilted.aperture.tilt_y_deg = -2.0;
  expect_bokeh_matches_lens_rays(tilted, -1, 2e-3f);
  tilted.aperture.axial_ca = 0.2;
  tilted.aperture.lateral_ca = 0.04;
  for (int band : {0, 2}) expect_bokeh_matches_lens_rays(tilted, band, 2e-3f);
  // The centre's own focus depth: a point on the tilted plane has no bokeh.
  const ThinLensCamera cam(glm::mat4(1.0f), kYfov, tilted, 200, 100);
  const glm::vec2 film(40.0f, 20.0f);
  const scene::Ray ray = cam.pinhole_ray(film);
  const double p = cam.imaging_at(ray.origin + ray.direction * 3.0f).lens.focus_distance;
  EXPECT_NEAR(cam.bokeh(film, p).scale, 0.0f, 1e-3f) << p;
  EXPECT_GT(std::abs(cam.bokeh(film, 1.5).scale), 1.0f);  // the untilted focus is not in focus
}

// Bit for bit (== would take -0 for 0).
bool same(const LensSample& a, const LensSample& b) {
  return std::memcmp(&a.ray.origin, &b.ray.origin, sizeof a.ray.origin) == 0 &&
         std::memcmp(&a.ray.direction, &b.ray.direction, sizeof a.ray.direction) == 0 &&
         std::memcmp(&a.weight, &b.weight, sizeof a.weight) == 0 &&
         a.ray.cull_back_faces == b.ray.cull_back_faces;
}

TEST(ThinLensCamera, LensRaysAreLensRayBitForBit) {
  // Through a real lens (traced several at a time) with a six-blade stop, and through a thin lens
  // with chromatic aberration and a vignetting stop; film points from the corners across the
  // frame, the bands in turn, a count that is not a multiple of a block.
  const int width = 200, height = 100;
  lens::ApertureShape blades(6, 0.0, 0.0, 1.0);
  const lens::MountedLens mounted =
      lens::mount_lens(lens::read_lens_file("double_gauss_50mm"), "double_gauss_50mm", 4.0, 3.0,
                       lens::Sensor{}, width, height, false, blades);
  lens::ThinLens thin{0.05, 2.0, 3.0};
  thin.aperture.axial_ca = 0.01;
  thin.aperture.stop = {0.01, 0.02};
  const ThinLensCamera cameras[] = {
      ThinLensCamera(glm::mat4(1.0f), kYfov, mounted.equivalent(), width, height, mounted),
      ThinLensCamera(glm::mat4(1.0f), kYfov, thin, width, height)};
  std::vector<glm::vec2> film = {{0.0f, 0.0f}, {200.0f, 0.0f}, {0.0f, 100.0f}, {200.0f, 100.0f},
                                 {100.0f, 50.0f}};
  std::vector<glm::vec2> u = {{0.5f, 0.5f}, {0.1f, 0.9f}, {0.9f, 0.1f}, {0.0f, 0.0f},
                              {0.99f, 0.99f}};
  for (int i = 0; film.size() < 37; ++i) {
    film.push_back({std::fmod(37.3f * i, 200.0f), std::fmod(11.9f * i, 100.0f)});
    u.push_back({std::fmod(0.618f * i, 1.0f), std::fmod(0.382f * i, 1.0f)});
  }
  std::vector<int> band;
  for (std::size_t i = 0; i < film.size(); ++i) band.push_back(static_cast<int>(i % 4) - 1);
  for (const ThinLensCamera& camera : cameras) {
    std::vector<LensSample> rays(film.size());
    camera.lens_rays(film.size(), film.data(), u.data(), band.data(), rays.data());
    int passed = 0;
    for (std::size_t i = 0; i < film.size(); ++i) {
      SCOPED_TRACE(i);
      EXPECT_TRUE(same(rays[i], camera.lens_ray(film[i], u[i], band[i])));
      passed += rays[i].weight > 0.0f;
    }
    EXPECT_GT(passed, 0);
    EXPECT_LT(passed, static_cast<int>(film.size()));  // stopped rays too
  }
}

}  // namespace
}  // namespace dofcache::render
