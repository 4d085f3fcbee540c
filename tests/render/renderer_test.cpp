// End-to-end properties of the integrators on scenes built in code.
#include "dofcache/render/renderer.h"

#include <gtest/gtest.h>

#include <cmath>

#include "dofcache/core/error.h"
#include "dofcache/scene/accel.h"
#include "test_scenes.h"

namespace dofcache::render {
namespace {

using testing::add_quad_z;

// A thin vertical emissive strip at depth D, nothing else: the image is the strip blurred by the
// lens. Measured along x, a line blurred by a disk of radius R has the chord profile
// sqrt(R^2 - x^2), whose variance is R^2/4; the pixel box filter adds 1/12 px^2 and the strip's own
// width w adds w^2/12. So the CoC diameter measured from the image is 4 sqrt(var - 1/12 - w^2/12).
struct StripSetup {
  static constexpr double kF = 0.1, kN = 1.0, kP = 1.0, kD = 2.0;
  static constexpr float kYfov = 0.2f;
  static constexpr int kW = 128, kH = 64;
  static constexpr float kStripWidth = 0.001f;  // metres
  scene::Scene scene;
  StripSetup() {
    scene.materials.push_back(testing::emissive_material(glm::vec3(1.0f)));
    add_quad_z(scene, -0.5f * kStripWidth, 0.5f * kStripWidth, -1.0f, 1.0f, -float(kD), 0, 0);
    testing::build_emitters(scene);
    scene.cameras.push_back(testing::origin_camera(kYfov));
  }
  RenderSettings settings(Mode mode, int spp) const {
    RenderSettings s;
    s.width = kW, s.height = kH, s.spp = spp, s.mode = mode;
    s.lens = lens::ThinLens{kF, kN, kP};
    s.progress = Progress::Display::Never;
    return s;
  }
};

double measured_coc_pixels(const image::Image& img, double strip_px) {
  double sum = 0, mean = 0, m2 = 0;
  for (int x = 0; x < img.width(); ++x) {
    double col = 0;
    for (int y = 0; y < img.height(); ++y) col += img.at(x, y, 0);
    double cx = x + 0.5;
    sum += col, mean += col * cx, m2 += col * cx * cx;
  }
  mean /= sum;
  double var = m2 / sum - mean * mean;
  return 4.0 * std::sqrt(std::max(0.0, var - 1.0 / 12.0 - strip_px * strip_px / 12.0));
}

class DefocusTest : public ::testing::TestWithParam<Mode> {};

TEST_P(DefocusTest, MeasuredBlurDiameterMatchesEq2_4) {
  StripSetup setup;
  scene::Accel accel(setup.scene);
  RenderSettings s = setup.settings(GetParam(), 256);
  RenderOutput out = render(setup.scene, accel, setup.scene.cameras[0], s);
  ThinLensCamera cam = make_camera(setup.scene.cameras[0], s);
  double expected = cam.imaging().signed_coc_pixels(StripSetup::kD);  // eq. (2.4) in pixels
  // Hand check of that value: V_P = 0.1/0.9, C = A V_P |D-P|/(D P) = 0.1*0.1111*1/2 = 5.556e-3 m,
  // pitch = 2 V_P tan(0.1) / 64 = 3.4844e-4 m, so C = 15.94 px.
  EXPECT_NEAR(expected, 15.94, 0.01);
  double strip_px = StripSetup::kStripWidth / cam.imaging().pixel_footprint(StripSetup::kD);
  double measured = measured_coc_pixels(out.color, strip_px);
  // Tolerance 3%: sampling noise of 256 lens samples and the discrete pixel grid.
  EXPECT_NEAR(measured, expected, 0.03 * expected) << "mode " << mode_name(GetParam());
}

INSTANTIATE_TEST_SUITE_P(LensModes, DefocusTest, ::testing::Values(Mode::Drt, Mode::Accumulation));

TEST(Renderer, PinholeIsSharp) {
  StripSetup setup;
  scene::Accel accel(setup.scene);
  RenderOutput out =
      render(setup.scene, accel, setup.scene.cameras[0], setup.settings(Mode::Pinhole, 16));
  // A line on a pixel boundary covers two pixels (discrete variance 1/4 px^2, not the 1/12 of the
  // smooth-profile correction), so "sharp" is under 2 px against the 16 px CoC of the DRT case.
  EXPECT_LT(measured_coc_pixels(out.color, 0.0), 2.0);
}

// A small closed-ish scene with an area light, walls and an occluder: exercises all shading paths.
scene::Scene shaded_scene() {
  scene::Scene s;
  s.materials.push_back(testing::diffuse_material({0.8f, 0.8f, 0.8f}));
  s.materials.push_back(testing::diffuse_material({0.8f, 0.1f, 0.1f}));
  s.materials.push_back(testing::emissive_material({8.0f, 8.0f, 8.0f}));
  scene::Material glossy = testing::diffuse_material({0.9f, 0.9f, 0.9f});
  glossy.metallic = 1.0f;
  glossy.roughness = 0.2f;
  s.materials.push_back(glossy);
  add_quad_z(s, -2, 2, -2, 2, -4.0f, 0, 0);      // back wall
  add_quad_z(s, -0.5f, 0.5f, -0.5f, 0.5f, -2.0f, 1, 1);  // red occluder
  add_quad_z(s, 0.6f, 1.0f, -1.0f, 0.0f, -2.5f, 3, 2);   // glossy metal panel
  add_quad_z(s, -0.3f, 0.3f, 0.8f, 1.2f, -1.0f, 2, 3);   // light, facing the back wall? (faces +Z)
  // A second light facing the scene (wound the other way, facing -Z) near the camera.
  testing::add_light_facing_away(s, 1.5f, 2.0f, -0.5f, 2, 4);
  testing::build_emitters(s);
  s.cameras.push_back(testing::origin_camera(0.9f));
  return s;
}

RenderSettings small_settings(int threads, std::uint64_t seed) {
  RenderSettings s;
  s.width = 40, s.height = 30, s.spp = 4, s.threads = threads, s.seed = seed;
  s.shading.light_samples = 2, s.shading.gather_rays = 4;
  s.lens = lens::ThinLens{0.05, 1.0, 2.0};
  s.progress = Progress::Display::Never;
  return s;
}

TEST(Renderer, SameSeedSameImageForAnyThreadCount) {
  scene::Scene s = shaded_scene();
  scene::Accel accel(s);
  RenderOutput a = render(s, accel, s.cameras[0], small_settings(1, 7));
  RenderOutput b = render(s, accel, s.cameras[0], small_settings(2, 7));
  RenderOutput c = render(s, accel, s.cameras[0], small_settings(2, 8));
  ASSERT_TRUE(a.color.same_shape(b.color));
  EXPECT_EQ(a.color.data(), b.color.data());
  EXPECT_NE(a.color.data(), c.color.data());
  double energy = 0;
  for (float v : a.color.data()) energy += v;
  EXPECT_GT(energy, 0.0);  // something is lit
  EXPECT_GT(a.stats.shading_points, 0u);
}

// The pattern seed alone places the film and lens samples: a scene of emitters only (nothing to
// shade) renders the same image with another seed and the same pattern seed, and another image
// with another pattern seed. What a camera path's frames share so their noise does not flicker.
TEST(Renderer, PatternSeedAlonePlacesTheFilmAndLensSamples) {
  scene::Scene s;
  s.materials.push_back(testing::emissive_material({1.0f, 0.5f, 0.25f}));
  add_quad_z(s, -0.4f, 0.4f, -0.3f, 0.3f, -4.0f, 0, 0);
  add_quad_z(s, -0.1f, 0.1f, -0.5f, 0.5f, -1.0f, 0, 1);  // out of focus: the lens decides
  testing::build_emitters(s);
  s.cameras.push_back(testing::origin_camera(0.9f));
  scene::Accel accel(s);
  RenderSettings a = small_settings(2, 7);
  a.pattern_seed = 99;
  RenderSettings b = a;
  b.seed = 8;
  RenderSettings c = a;
  c.pattern_seed = 100;
  const RenderOutput ra = render(s, accel, s.cameras[0], a);
  EXPECT_EQ(ra.color.data(), render(s, accel, s.cameras[0], b).color.data());
  EXPECT_NE(ra.color.data(), render(s, accel, s.cameras[0], c).color.data());
}

TEST(Renderer, NearPlaneHidesNearerSurfaces) {
  scene::Scene s = shaded_scene();
  scene::Accel accel(s);
  RenderSettings st = small_settings(2, 1);
  st.visibility_only = true;
  RenderOutput full = render(s, accel, s.cameras[0], st);
  EXPECT_EQ(full.ids.at(20, 15, 0), 1.0f);  // the red occluder in the centre
  EXPECT_NEAR(full.depth.at(20, 15, 0), 2.0f, 1e-4f);
  st.near_depth = 3.0f;
  RenderOutput clipped = render(s, accel, s.cameras[0], st);
  EXPECT_EQ(clipped.ids.at(20, 15, 0), 0.0f);  // the back wall behind it
  EXPECT_NEAR(clipped.depth.at(20, 15, 0), 4.0f, 1e-4f);
}

TEST(Renderer, ClippedRenderMarksTheInsideOfObjects) {
  // Behind the near plane a ray that first meets the back of a one-sided surface is inside an
  // object whose front the plane removed: no lens ray sees that surface (clipped renders keep
  // back faces, which camera rays otherwise cull).
  scene::Scene s;
  s.materials = {testing::diffuse_material(glm::vec3(0.5f)),
                 testing::diffuse_material(glm::vec3(0.5f))};
  s.materials[1].double_sided = true;
  testing::add_quad_z(s, -3, 3, -3, 3, -4.0f, 0, 0);  // faces the camera
  testing::add_quad(s, {glm::vec3(-1, -1, -2), glm::vec3(-1, 1, -2), glm::vec3(1, 1, -2),
                        glm::vec3(1, -1, -2)},
                    {0.0f, 0.0f, -1.0f}, 0, 1);  // its back faces the camera
  s.cameras.push_back(testing::origin_camera(0.9f));
  scene::Accel accel(s);
  RenderSettings st = small_settings(2, 1);
  st.visibility_only = true;
  // No near plane: glTF culls the back of the one-sided quad, the camera sees the wall behind it.
  EXPECT_EQ(render(s, accel, s.cameras[0], st).ids.at(20, 15, 0), 0.0f);
  st.near_depth = 1.0f;
  EXPECT_EQ(render(s, accel, s.cameras[0], st).ids.at(20, 15, 0), kInsideId);
  EXPECT_EQ(render(s, accel, s.cameras[0], st).ids.at(1, 1, 0), 0.0f);  // past the quad
  s.mesh.triangle_material[2] = s.mesh.triangle_material[3] = 1;  // double-sided: a real surface
  scene::Accel accel2(s);
  EXPECT_EQ(render(s, accel2, s.cameras[0], st).ids.at(20, 15, 0), 1.0f);
}

// trace_pixel_centres gives what a visibility-only render() gives at the listed pixels, in the
// list's order: with and without a near plane (which clips the occluder and cuts the inside-marked
// quad open), object and triangle ids.
TEST(Renderer, TracedPixelCentresEqualTheVisibilityRender) {
  scene::Scene s = shaded_scene();
  s.materials.push_back(testing::diffuse_material(glm::vec3(0.5f)));
  testing::add_quad(s, {glm::vec3(-1, -1, -2.5f), glm::vec3(-1, 1, -2.5f), glm::vec3(1, 1, -2.5f),
                        glm::vec3(1, -1, -2.5f)},
                    {0.0f, 0.0f, -1.0f}, static_cast<std::uint32_t>(s.materials.size() - 1), 5);
  scene::Accel accel(s);
  RenderSettings st = small_settings(2, 1);
  st.visibility_only = true;
  for (float near : {0.0f, 2.2f, 3.0f})
    for (bool triangles : {false, true}) {
      st.near_depth = near;
      st.triangle_ids = triangles;
      const RenderOutput full = render(s, accel, s.cameras[0], st);
      std::vector<std::uint32_t> pixels;  // every pixel, backwards, and one twice
      for (int p = st.width * st.height - 1; p >= 0; --p) pixels.push_back(p);
      pixels.push_back(7);
      const std::vector<PixelVisibility> seen =
          trace_pixel_centres(s, accel, s.cameras[0], st, pixels);
      ASSERT_EQ(seen.size(), pixels.size());
      int inside = 0, hits = 0;
      for (size_t i = 0; i < pixels.size(); ++i) {
        const int x = pixels[i] % st.width, y = pixels[i] / st.width;
        ASSERT_EQ(seen[i].id, full.ids.at(x, y, 0)) << x << "," << y << " near " << near;
        ASSERT_EQ(seen[i].depth, full.depth.at(x, y, 0)) << x << "," << y << " near " << near;
        inside += seen[i].id == kInsideId;
        hits += seen[i].id >= 0;
      }
      EXPECT_GT(hits, 0);
      if (near == 2.2f) {
        EXPECT_GT(inside, 0) << "the near plane should cut the quad open";
      }
    }
  EXPECT_THROW(trace_pixel_centres(s, accel, s.cameras[0], st,
                                   {static_cast<std::uint32_t>(st.width * st.height)}),
               Error);
}

// render_pixels gives what a masked render() gives at the listed pixels (colour, depth, id),
// bit for bit, in every integrator without a cache, with and without a near plane.
TEST(Renderer, RenderedPixelsEqualTheMaskedRender) {
  scene::Scene s = shaded_scene();
  scene::Accel accel(s);
  RenderSettings st = small_settings(2, 3);
  image::Image mask(st.width, st.height, 1, 0.0f);
  std::vector<std::uint32_t> pixels;
  for (int p = st.width * st.height - 1; p >= 0; p -= 7) {  // backwards, a scattered subset
    mask.data()[p] = 1.0f;
    pixels.push_back(static_cast<std::uint32_t>(p));
  }
  for (Mode mode : {Mode::Pinhole, Mode::Drt, Mode::Accumulation})
    for (float near : {0.0f, 3.0f}) {
      st.mode = mode;
      st.near_depth = near;
      st.mask = &mask;
      const RenderOutput full = render(s, accel, s.cameras[0], st);
      st.mask = nullptr;
      const std::vector<PixelRender> seen = render_pixels(s, accel, s.cameras[0], st, pixels);
      ASSERT_EQ(seen.size(), pixels.size());
      double total = 0;
      for (size_t i = 0; i < pixels.size(); ++i) {
        const int x = pixels[i] % st.width, y = pixels[i] / st.width;
        for (int k = 0; k < 3; ++k)
          ASSERT_EQ(seen[i].color[k], full.color.at(x, y, k)) << x << "," << y << " " << mode_name(mode);
        ASSERT_EQ(seen[i].depth, full.depth.at(x, y, 0)) << x << "," << y;
        ASSERT_EQ(seen[i].id, full.ids.at(x, y, 0)) << x << "," << y;
        total += seen[i].color.x + seen[i].color.y + seen[i].color.z;
      }
      EXPECT_GT(total, 0.0) << "a black image would prove nothing";
    }
  st.adaptive.enabled = true;
  st.mode = Mode::Drt;
  EXPECT_THROW(render_pixels(s, accel, s.cameras[0], st, pixels), Error);
  st.adaptive.enabled = false;
  EXPECT_THROW(render_pixels(s, accel, s.cameras[0], st,
                             {static_cast<std::uint32_t>(st.width * st.height)}),
               Error);
}

// glTF sides and cut-outs as the camera sees them. A diffuse quad (albedo 0.5) at z = -2 fills
// the centre of a pinhole view; a directional light of 2 pi sqrt2 lux comes from the camera's
// side at 45 degrees, so a lit Lambertian point shows 0.5 / pi * 2 pi sqrt2 * cos 45 = 1 (plus
// a little of the glTF BRDF's specular lobe). Direct light only.
TEST(Renderer, SidesAndCutOutShadowsAsGltfDefinesThem) {
  auto scene = [](bool faces_camera, bool double_sided, int occluder_alpha_mode) {
    scene::Scene s;
    s.materials = {testing::diffuse_material(glm::vec3(0.5f)),
                   testing::diffuse_material(glm::vec3(0.5f))};
    s.materials[0].double_sided = double_sided;
    if (faces_camera)
      add_quad_z(s, -1, 1, -1, 1, -2.0f, 0, 0);
    else
      testing::add_quad(s, {glm::vec3(-1, -1, -2), glm::vec3(-1, 1, -2), glm::vec3(1, 1, -2),
                            glm::vec3(1, -1, -2)},
                        {0.0f, 0.0f, -1.0f}, 0, 0);
    if (occluder_alpha_mode >= 0) {
      // On the centre point's shadow ray (towards (-1, 0, 1)) at z = -1, off the view ray.
      add_quad_z(s, -1.5f, -0.5f, -0.5f, 0.5f, -1.0f, 1, 1);
      s.materials[1].alpha_mode = static_cast<scene::AlphaMode>(occluder_alpha_mode);
      s.materials[1].base_color.a = 0.0f;  // a MASK cut-out everywhere
    }
    scene::PunctualLight sun;
    sun.type = scene::PunctualLight::Type::Directional;
    sun.direction = glm::normalize(glm::vec3(1, 0, -1));
    sun.intensity = glm::vec3(2.0f * 3.14159265f * std::sqrt(2.0f));
    s.lights.push_back(sun);
    s.cameras.push_back(testing::origin_camera(0.3f));
    return s;
  };
  auto centre = [](const scene::Scene& s) {
    scene::Accel accel(s);
    RenderSettings st = small_settings(1, 3);
    st.mode = Mode::Pinhole;
    st.shading.gather_rays = 0, st.shading.bounces = 0;
    return render(s, accel, s.cameras[0], st).color.at(20, 15, 1);
  };
  const float front = centre(scene(true, false, -1));
  EXPECT_NEAR(front, 1.0f, 0.1f);
  // The back of a double-sided quad shades with the flipped normal: exactly like a front.
  EXPECT_NEAR(centre(scene(false, true, -1)), front, 1e-5f);
  // The back of a single-sided quad is not there for the camera: the black background.
  EXPECT_EQ(centre(scene(false, false, -1)), 0.0f);
  // An opaque occluder shadows the centre; a MASK one cut out everywhere does not.
  EXPECT_EQ(centre(scene(true, false, static_cast<int>(scene::AlphaMode::Opaque))), 0.0f);
  EXPECT_NEAR(centre(scene(true, false, static_cast<int>(scene::AlphaMode::Mask))), front, 1e-5f);
}

TEST(Renderer, MaskRestrictsRenderedPixels) {
  scene::Scene s = shaded_scene();
  scene::Accel accel(s);
  RenderSettings st = small_settings(2, 1);
  image::Image mask(st.width, st.height, 1, 0.0f);
  for (int y = 0; y < st.height; ++y)
    for (int x = 0; x < st.width / 2; ++x) mask.at(x, y, 0) = 1.0f;
  st.mask = &mask;
  RenderOutput out = render(s, accel, s.cameras[0], st);
  double left = 0, right = 0;
  for (int y = 0; y < st.height; ++y)
    for (int x = 0; x < st.width; ++x) (x < st.width / 2 ? left : right) += out.color.at(x, y, 0);
  EXPECT_GT(left, 0.0);
  EXPECT_EQ(right, 0.0);
  EXPECT_EQ(out.ids.at(st.width - 1, 0, 0), -1.0f);
}

TEST(Renderer, RejectsAbsurdSettings) {
  scene::Scene s = shaded_scene();
  scene::Accel accel(s);
  RenderSettings st = small_settings(1, 1);
  st.width = 0;
  EXPECT_THROW(render(s, accel, s.cameras[0], st), Error);
  st = small_settings(1, 1);
  st.lens.fstop = -2.0;
  EXPECT_THROW(render(s, accel, s.cameras[0], st), Error);
  st = small_settings(1, 1);
  st.shading.gather_rays = -1;
  EXPECT_THROW(render(s, accel, s.cameras[0], st), Error);
}

// A wall at depth 4 (albedo 0.3, 0.5, 0.7) covering the left of the view, the sky (black) on the
// right, a lamp (radiance 5, albedo 0) at depth 1 in front of the wall, far out of focus (the lens
// is focused on the wall), and a light facing the wall from behind the camera's view.
struct FeatureScene {
  static constexpr float kLamp = 5.0f;
  scene::Scene scene;
  FeatureScene() {
    scene.materials.push_back(testing::diffuse_material({0.3f, 0.5f, 0.7f}));
    scene.materials.push_back(testing::emissive_material(glm::vec3(kLamp)));
    scene.materials.push_back(testing::emissive_material(glm::vec3(20.0f)));
    add_quad_z(scene, -20.0f, 0.5f, -20.0f, 20.0f, -4.0f, 0, 0);
    add_quad_z(scene, -0.12f, -0.02f, -0.05f, 0.05f, -1.0f, 1, 1);
    testing::add_light_facing_away(scene, 1.5f, 2.5f, -0.5f, 2, 2);
    testing::build_emitters(scene);
    scene.cameras.push_back(testing::origin_camera(0.6f));
  }
  RenderSettings settings(int spp) const {
    RenderSettings s;
    s.width = 48, s.height = 32, s.spp = spp, s.seed = 3;
    s.lens = lens::ThinLens{0.05, 1.0, 4.0};
    s.progress = Progress::Display::Never;
    s.lens_features = true;
    return s;
  }
};

TEST(Renderer, LensFeaturesAverageTheFirstHitsOverTheLensSamples) {
  FeatureScene f;
  scene::Accel accel(f.scene);
  const RenderOutput out = render(f.scene, accel, f.scene.cameras[0], f.settings(16));
  RenderSettings plain = f.settings(16);
  plain.lens_features = false;
  const RenderOutput raw = render(f.scene, accel, f.scene.cameras[0], plain);
  EXPECT_EQ(out.color.data(), raw.color.data());  // no colour changed
  // Rays added: the emission's extra samples only, at least 64 per pixel where it varies.
  EXPECT_EQ(out.stats.camera_rays, raw.stats.camera_rays);
  EXPECT_GT(out.stats.rays, raw.stats.rays);
  EXPECT_TRUE(raw.lens_features.empty());

  const LensFeatures& lf = out.lens_features;
  const glm::vec3 wall(0.3f, 0.5f, 0.7f);
  int lamp_pixels = 0, sky_pixels = 0, wall_pixels = 0;
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 48; ++x) {
      const float cover = lf.coverage.at(x, y, 0);
      if (cover == 0.0f) {  // the sky: nothing hit
        ++sky_pixels;
        EXPECT_TRUE(std::isinf(lf.depth.at(x, y, 0)));
        EXPECT_EQ(lf.albedo.at(x, y, 1), 0.0f);
        continue;
      }
      if (cover < 1.0f) continue;  // the wall's edge, in focus: a few pixels
      // Each sample met the lamp (albedo 0, depth 1, emission 5) or the wall (its albedo, depth
      // 4, no emission): the lamp's share t follows from the emission, and every other
      // average must be the same mix.
      const float t = lf.emission.at(x, y, 0) / FeatureScene::kLamp;
      lamp_pixels += t > 0.0f;
      wall_pixels += t == 0.0f;
      for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(lf.albedo.at(x, y, c), wall[c] * (1.0f - t), 1e-5f) << x << "," << y;
      EXPECT_NEAR(lf.depth.at(x, y, 0), 4.0f * (1.0f - t) + 1.0f * t, 1e-4f) << x << "," << y;
      EXPECT_NEAR(lf.normal.at(x, y, 2), 1.0f, 1e-5f);
    }
  EXPECT_GT(lamp_pixels, 20);  // the lamp's blur disc is some 14 pixels across
  EXPECT_GT(sky_pixels, 100);
  EXPECT_GT(wall_pixels, 300);

  // The measured noise: on the lit wall (no lamp in front), the variance of a pixel's mean
  // against the spread of neighbouring pixels' means, (x_i - x_i+1)^2 / 2 (the lighting's slow
  // change cancels). One sample per pixel measures none.
  double measured = 0, spread = 0;
  int pairs = 0;
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x + 1 < 24; ++x) {
      if (lf.emission.at(x, y, 0) > 0.0f || lf.emission.at(x + 1, y, 0) > 0.0f) continue;
      const double a = scene::luminance(glm::vec3(out.color.at(x, y, 0), out.color.at(x, y, 1),
                                                  out.color.at(x, y, 2)));
      const double b = scene::luminance(glm::vec3(out.color.at(x + 1, y, 0),
                                                  out.color.at(x + 1, y, 1),
                                                  out.color.at(x + 1, y, 2)));
      spread += 0.5 * (a - b) * (a - b);
      measured += lf.variance.at(x, y, 0);
      ++pairs;
    }
  ASSERT_GT(pairs, 300);
  EXPECT_GT(measured, 0.0);
  EXPECT_NEAR(measured / spread, 1.0, 0.3) << measured / pairs << " vs " << spread / pairs;
  const RenderOutput one = render(f.scene, accel, f.scene.cameras[0], f.settings(1));
  for (float v : one.lens_features.variance.data()) EXPECT_EQ(v, 0.0f);
}

// The emission and albedo estimates: where the lamp's blur disc makes them vary, more samples,
// so nearer those of a render with many samples than the colour's own samples' are.
TEST(Renderer, FeatureEstimatesIntegrateTheLampsBokehWithMoreSamples) {
  FeatureScene f;
  scene::Accel accel(f.scene);
  const RenderOutput few = render(f.scene, accel, f.scene.cameras[0], f.settings(4));
  const RenderOutput many = render(f.scene, accel, f.scene.cameras[0], f.settings(256));
  const LensFeatures& a = few.lens_features;
  double own = 0, estimate = 0, estimate_sum = 0, truth_sum = 0, own_albedo = 0,
         estimate_albedo = 0;
  int pixels = 0;
  for (std::size_t i = 0; i < a.emission.pixel_count(); ++i) {
    const float truth = many.lens_features.emission.data()[i * 3];
    if (truth == 0.0f && a.emission.data()[i * 3] == 0.0f) continue;
    ++pixels;
    own += std::pow(a.emission.data()[i * 3] - truth, 2);
    estimate += std::pow(a.emission_estimate.data()[i * 3] - truth, 2);
    estimate_sum += a.emission_estimate.data()[i * 3];
    truth_sum += truth;
    // The albedo there (the lamp's is 0, the wall's behind it not): the same mix.
    const float albedo = many.lens_features.albedo.data()[i * 3 + 2];
    own_albedo += std::pow(a.albedo.data()[i * 3 + 2] - albedo, 2);
    estimate_albedo += std::pow(a.albedo_estimate.data()[i * 3 + 2] - albedo, 2);
  }
  ASSERT_GT(pixels, 20);
  // 4 samples against at least 68, judged by 256: the squared error should fall about 13-fold;
  // ask for 5.
  EXPECT_LT(estimate, own / 5.0);
  EXPECT_NEAR(estimate_sum / truth_sum, 1.0, 0.03);  // the lamp's energy, kept
  EXPECT_LT(estimate_albedo, own_albedo / 5.0);
}

}  // namespace
}  // namespace dofcache::render
