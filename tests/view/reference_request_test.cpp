// The viewer's reference is the render a user gets from `render` with the same request: its first
// pass equals request::render_image of that request with the pass's samples and seed (and the
// viewer's named policy, the sample quality of 64 lens samples, given explicitly).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <optional>
#include <thread>

#include "scratch_dir.h"

#include "dofcache/render/setup.h"
#include "dofcache/request/image_render.h"
#include "dofcache/view/session.h"

using namespace dofcache;

namespace {

class ViewReference : public dofcache::testing::ScratchDirTest {};

TEST_F(ViewReference, FirstPassEqualsRenderOfTheSameRequest) {
  view::ViewSettings v;
  v.request.width = 32;
  v.request.height = 24;
  v.request.shading = render::ShadingSettings{};
  v.request.shading->gather_rays = 4;
  v.request.shading->light_samples = 1;
  v.request.seed = 11;
  v.reference_pass_spp = 4;
  v.reference_max_spp = 4;
  const render::LensOverrides lens{0.1, 1.4, 3.0, {}, {}};
  view::ViewSession session(render::load_scene(""), lens, v);
  session.start();
  std::optional<view::ViewImage> ref;
  for (int i = 0; i < 1200 && !(ref && ref->reference_spp == 4); ++i) {
    ref = session.reference();
    if (!session.status().error.empty()) FAIL() << session.status().error;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ASSERT_TRUE(ref && ref->reference_spp == 4);
  session.stop();

  // `render --spp 4 --seed <pass seed> --cache-sample-quality 32` of the same options.
  request::RenderRequest r = v.request;
  r.kind = request::Kind::Image;
  r.core_policy = CorePolicy::AllCores;
  r.spp = 4;
  r.seed = view::reference_pass_seed(11, 1);
  r.lens = lens;
  // The viewer's policy: the quality of 64 lens samples, with 4 gather rays that of
  // 64 * 32 / 4 = 512 lens samples at the default 32: round(512 / 16) = 32.
  r.cache_settings.sample_quality = 32;
  r.out = (dir_ / "render.exr").string();
  const scene::Scene scene = render::load_scene("");
  const scene::Accel accel(scene);
  const scene::Camera& camera = scene.camera_or_first("");
  const request::ResolvedRequest resolved = request::resolve(r, scene, accel, camera);
  EXPECT_EQ(resolved.cache_backend, "vdb");
  EXPECT_TRUE(resolved.settings.adaptive.enabled);  // auto: on for drt, in both
  const request::ImageResult out = request::render_image(resolved, scene, accel, camera);
  ASSERT_TRUE(out.render.has_value());
  ASSERT_EQ(out.render->color.data().size(), ref->color.data().size());
  double worst = 0;
  for (std::size_t i = 0; i < ref->color.data().size(); ++i)
    worst = std::max(worst, double(std::abs(out.render->color.data()[i] - ref->color.data()[i])));
  EXPECT_TRUE(out.render->color.data() == ref->color.data()) << "largest difference " << worst;
}

}  // namespace
