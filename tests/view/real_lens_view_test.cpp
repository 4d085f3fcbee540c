// `dofcache view` through a real lens (view/session.h): a click focuses the traced lens, which
// breathes, so the pinhole inputs are seen again from its moved principal plane; leaving the lens
// keeps the focus distance from the sensor. Depths are checked against the scene's geometry.
#include <gtest/gtest.h>

#include <string>

#include "dofcache/core/error.h"
#include "dofcache/view/session.h"
#include "render/test_scenes.h"

namespace dofcache::view {
namespace {

constexpr int kWidth = 48, kHeight = 32;

// An emissive wall 1 m in front of the camera node (the sensor) on the left, 4 m on the right.
scene::Scene two_walls() {
  scene::Scene s;
  s.materials.push_back(testing::emissive_material({0.8f, 0.8f, 0.8f}));
  s.materials.push_back(testing::emissive_material({0.2f, 0.2f, 0.2f}));
  testing::add_quad_z(s, -5.0f, 0.0f, -5.0f, 5.0f, -1.0f, 0, 0);
  testing::add_quad_z(s, -20.0f, 20.0f, -20.0f, 20.0f, -4.0f, 1, 1);
  testing::build_emitters(s);
  s.cameras.push_back(testing::origin_camera(0.8f));
  return s;
}

ViewSettings small() {
  ViewSettings s;
  s.request.width = kWidth;
  s.request.height = kHeight;
  s.input_spp = 1;
  s.reference = false;
  return s;
}

TEST(ViewRealLens, FocusingBreathesAndTheInputsAreSeenFromItsPrincipalPlane) {
  render::LensOverrides lens;
  lens.real.file = "double_gauss_50mm";
  lens.focus_distance = 4.0;  // from the sensor
  ViewSession session(two_walls(), lens, small());
  session.start();
  ASSERT_TRUE(session.wait_for_stage(InputStage::Refined, 60.0));
  const ViewStatus far = session.status();
  ASSERT_TRUE(far.real_lens);
  EXPECT_NEAR(far.lens.focal_length, 0.0504, 0.0002);
  EXPECT_NEAR(far.real_lens.lens->focus_distance(), 4.0, 1e-9);
  // Its previews draw the lens's own cat's eyes (lens/lens_rims.h).
  EXPECT_TRUE(far.lens.aperture.rims.any());
  // The pinhole sits at the front principal plane, so the near wall's depth is 1 m less its
  // distance from the sensor.
  const int x = kWidth / 4, y = kHeight / 2;
  EXPECT_NEAR(session.depth_at(x, y), 1.0 - far.real_lens.principal_offset(), 1e-4);

  // A click on the near wall focuses the lens 1 m from the sensor: the lens moves out (its
  // principal plane too) and sees less (it breathes), so the inputs are rendered again.
  session.focus_at(x, y);
  const ViewStatus near = session.status();
  EXPECT_NEAR(near.real_lens.lens->focus_distance(), 1.0, 1e-4);
  EXPECT_GT(near.camera_version, far.camera_version);
  EXPECT_LT(near.real_lens.yfov(), far.real_lens.yfov());
  EXPECT_GT(near.real_lens.principal_offset(), far.real_lens.principal_offset() + 1e-3);
  ASSERT_TRUE(session.wait_for_stage(InputStage::Refined, 60.0));
  EXPECT_NEAR(session.depth_at(x, y), 1.0 - near.real_lens.principal_offset(), 1e-4);

  // Too wide a stop is refused and changes nothing.
  lens::ThinLens wide = session.lens();
  wide.fstop = 1.4;
  EXPECT_THROW(session.set_lens(wide), Error);
  EXPECT_EQ(session.status().lens_version, near.lens_version);
  EXPECT_THROW(session.set_real_lens("no_such_lens"), Error);
  EXPECT_TRUE(session.status().real_lens);

  // Back to the thin lens: the focal length and f-number it looked through, the focus distance
  // from the sensor (the camera node), the scene camera's own field of view.
  const lens::ThinLens thin = session.set_real_lens("");
  EXPECT_NEAR(thin.focal_length, 0.0504, 0.0002);
  EXPECT_NEAR(thin.focus_distance, 1.0, 1e-4);
  EXPECT_FALSE(thin.aperture.rims.any());  // the real lens's own cat's eyes stay with it
  EXPECT_FALSE(session.status().real_lens);
  ASSERT_TRUE(session.wait_for_stage(InputStage::Refined, 60.0));
  EXPECT_NEAR(session.depth_at(x, y), 1.0, 1e-4);
  session.stop();
}

}  // namespace
}  // namespace dofcache::view
