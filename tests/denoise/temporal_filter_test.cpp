// The temporal filter against scenes whose frames are known exactly: a textured plane seen by a
// still and by a moving camera (independent noise per frame is averaged away, the texture stays
// put), a square in front of a wall (what a neighbour frame shows of the other surface never comes
// in), a highlight that moves and a focus pull (refused).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "dofcache/core/error.h"
#include "dofcache/core/rng.h"
#include "dofcache/denoise/temporal_filter.h"

using namespace dofcache;
using image::Image;

namespace {

constexpr int kW = 48, kH = 32;
constexpr float kInf = std::numeric_limits<float>::infinity();

// A pinhole camera at (cx, 0, 0) looking down -Z with +Y up, 60 degrees vertical field of view:
// film position (x, y) at depth z is the world point (cx + z sx, z sy, -z), sx and sy the film
// position's tangents. Written out here rather than taken from the renderer's camera.
constexpr float kTanHalfY = 0.57735027f;  // tan 30 degrees
constexpr float kTanHalfX = kTanHalfY * kW / kH;

glm::vec3 world_point(float cx, float x, float y, float z) {
  const float sx = (2.0f * x / kW - 1.0f) * kTanHalfX, sy = (1.0f - 2.0f * y / kH) * kTanHalfY;
  return {cx + z * sx, z * sy, -z};
}

glm::mat4 film_to_world(float cx) {
  // Columns: the images of x z, y z, z and 1 (world_point is affine in them).
  return glm::mat4(glm::vec4(2.0f * kTanHalfX / kW, 0, 0, 0),
                   glm::vec4(0, -2.0f * kTanHalfY / kH, 0, 0),
                   glm::vec4(-kTanHalfX, kTanHalfY, -1, 0), glm::vec4(cx, 0, 0, 1));
}

// One frame: what each pixel's centre ray sees (depth, colour), with noise of standard
// deviation sd added to the colour and its variance recorded.
struct Frame {
  Image color{kW, kH, 3, 0.0f}, depth{kW, kH, 1, kInf}, normal{kW, kH, 3, 0.0f},
      ids{kW, kH, 1, -1.0f},
      coc{kW, kH, 1, 0.0f}, variance{kW, kH, 1, 0.0f};
  Image truth{kW, kH, 1, 0.0f};
  glm::mat4 film_to_world{1.0f};

  denoise::TemporalFrame view() const {
    return {&color, &depth, &normal, &ids, &coc, &variance, film_to_world};
  }
};

// The world: planes facing the camera (normal +Z). `surface(x, y)` of a world point's x and y
// on the wall at depth 4 gives its grey value; a square |x|, |y| < half at depth 1 (if half > 0)
// has value 1.
struct World {
  float square_half = 0.0f;
  float (*wall)(float, float) = [](float x, float y) {
    return 0.5f + 0.3f * std::sin(1.3f * x) * std::cos(0.9f * y);
  };
};

Frame render_frame(const World& world, float camera_x, float sd, std::uint64_t seed) {
  Frame f;
  f.film_to_world = film_to_world(camera_x);
  Rng rng(seed, 0);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      float value = 0.0f, depth = kInf;
      for (float z : {1.0f, 4.0f}) {  // nearest plane the ray meets
        const glm::vec3 p = world_point(camera_x, x + 0.5f, y + 0.5f, z);
        if (z == 1.0f) {
          if (world.square_half > 0 && std::abs(p.x) < world.square_half &&
              std::abs(p.y) < world.square_half) {
            value = 1.0f, depth = 1.0f;
            break;
          }
          continue;
        }
        value = world.wall(p.x, p.y), depth = 4.0f;
      }
      float n = 0.0f;  // a sum of uniforms: mean 0, variance 1
      for (int k = 0; k < 12; ++k) n += rng.uniform();
      const float v = value + sd * (n - 6.0f);
      for (int c = 0; c < 3; ++c) f.color.pixel(x, y)[c] = v;
      f.truth.at(x, y, 0) = value;
      f.depth.at(x, y, 0) = depth;
      f.ids.at(x, y, 0) = depth == 1.0f ? 1.0f : depth == 4.0f ? 0.0f : -1.0f;
      f.normal.pixel(x, y)[2] = 1.0f;
      f.variance.at(x, y, 0) = sd * sd;
    }
  return f;
}

std::vector<denoise::TemporalFrame> views(const std::vector<Frame>& frames) {
  std::vector<denoise::TemporalFrame> v;
  for (const Frame& f : frames) v.push_back(f.view());
  return v;
}

// Mean squared difference from the truth over the inner pixels (a border of `margin`).
double mse(const Image& img, const Image& truth, int margin = 4) {
  double s = 0;
  int n = 0;
  for (int y = margin; y < kH - margin; ++y)
    for (int x = margin; x < kW - margin; ++x, ++n) {
      const double d = img.at(x, y, 0) - truth.at(x, y, 0);
      s += d * d;
    }
  return s / n;
}

TEST(TemporalFilter, AveragesIndependentNoiseOfAStillCamera) {
  std::vector<Frame> frames;
  for (int i = 0; i < 5; ++i) frames.push_back(render_frame({}, 0.0f, 0.05f, 10 + i));
  const Image out = denoise::temporal_filter(views(frames), 2);
  // Five frames of independent noise: a fifth of the variance (0.0025 / 5).
  const double before = mse(frames[2].color, frames[2].truth, 0);
  const double after = mse(out, frames[2].truth, 0);
  EXPECT_NEAR(before, 0.0025, 0.0004);
  EXPECT_LT(after, 0.0025 / 5 * 1.3);
  EXPECT_GT(after, 0.0025 / 5 * 0.7);
}

TEST(TemporalFilter, FollowsTheTextureOfAMovingCamera) {
  // A texture of period 2.1 m on the wall (14.5 px at its depth of 4 m: film height 2 tan 30deg
  // per unit depth over 32 px), the camera moving 0.3 m (2.1 px) a frame.
  World world;
  world.wall = [](float x, float y) { return 0.5f + 0.3f * std::sin(3.0f * x) * std::cos(0.9f * y); };
  std::vector<Frame> frames;
  for (int i = 0; i < 5; ++i) frames.push_back(render_frame(world, 0.3f * (i - 2), 0.05f, 20 + i));
  const Image out = denoise::temporal_filter(views(frames), 2);
  EXPECT_LT(mse(out, frames[2].truth), 0.0025 * 0.35);
  // Taken as a still camera (every frame given the centre's camera) the texture would smear.
  std::vector<denoise::TemporalFrame> unmoved = views(frames);
  for (auto& v : unmoved) v.film_to_world = frames[2].film_to_world;
  denoise::TemporalFilterOptions loose;
  loose.sigma_luminance = 1e6f;  // only the reprojection decides
  const Image smeared = denoise::temporal_filter(unmoved, 2, loose);
  const Image followed = denoise::temporal_filter(views(frames), 2, loose);
  EXPECT_LT(mse(followed, frames[2].truth), 0.5 * mse(smeared, frames[2].truth));
}

TEST(TemporalFilter, NeverBringsInWhatANeighbourShowsOfAnotherSurface) {
  // Noise-free frames of a square 1 m in front of the wall, the camera moving 0.3 m a frame: the
  // square's image shifts by several pixels against the wall's, uncovering and covering wall.
  World world;
  world.square_half = 0.3f;
  world.wall = [](float, float) { return 0.2f; };
  std::vector<Frame> frames;
  for (int i = 0; i < 5; ++i) frames.push_back(render_frame(world, 0.3f * (i - 2), 0.0f, 1));
  denoise::TemporalFilterOptions loose;
  loose.sigma_luminance = 1e6f;  // the luminance test would hide a wrong depth test
  loose.relative_luminance = 1e6f;
  const Image out = denoise::temporal_filter(views(frames), 2, loose);
  int square = 0;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      ASSERT_NEAR(out.at(x, y, 0), frames[2].truth.at(x, y, 0), 1e-5f) << x << "," << y;
      square += frames[2].truth.at(x, y, 0) == 1.0f;
    }
  EXPECT_GT(square, 20);  // the square is in the picture
}

TEST(TemporalFilter, KeepsAHighlightThatMovesAndRefusesAnotherBlur) {
  // A still camera; each frame has a bright spot (value 3) at its own place, and low noise.
  std::vector<Frame> frames;
  for (int i = 0; i < 5; ++i) {
    frames.push_back(render_frame({}, 0.0f, 0.01f, 30 + i));
    for (int y = 10; y < 14; ++y)
      for (int x = 8 + 6 * i; x < 12 + 6 * i; ++x)
        for (int c = 0; c < 3; ++c) frames[i].color.pixel(x, y)[c] = 3.0f;
  }
  // Frame 0 is in another focus: its circles of confusion are 6 px, its colour darker.
  for (std::size_t j = 0; j < frames[0].coc.pixel_count(); ++j) {
    frames[0].coc.data()[j] = 6.0f;
    for (int c = 0; c < 3; ++c) frames[0].color.data()[3 * j + c] *= 0.9f;
  }
  const Image out = denoise::temporal_filter(views(frames), 2);
  for (int y = 10; y < 14; ++y)
    for (int x = 20; x < 24; ++x) EXPECT_NEAR(out.at(x, y, 0), 3.0f, 1e-4f);  // its own spot
  // Elsewhere the spots of the others are not brought in, nor frame 0's darker blur: the mean
  // of the wall away from every spot stays the truth's.
  double diff = 0;
  int n = 0;
  for (int y = 16; y < kH; ++y)
    for (int x = 0; x < kW; ++x, ++n) diff += out.at(x, y, 0) - frames[2].truth.at(x, y, 0);
  EXPECT_NEAR(diff / n, 0.0, 0.002);
  for (int y = 10; y < 14; ++y)
    for (int x = 8; x < 12; ++x) EXPECT_LT(out.at(x, y, 0), 1.0f);  // frame 0's spot
}

TEST(TemporalFilter, AFrameFarNoisierThanTheOthersHardlyCounts) {
  // Still camera, noise-free frames; the centre frame's pixel (10, 10) caught a rare bright
  // sample (value 2, variance 1), frame 3's pixel (30, 10) too.
  std::vector<Frame> frames;
  for (int i = 0; i < 5; ++i) frames.push_back(render_frame({}, 0.0f, 0.0f, 40 + i));
  for (auto [f, x] : {std::pair{2, 10}, std::pair{3, 30}}) {
    for (int c = 0; c < 3; ++c) frames[f].color.pixel(x, 10)[c] = 2.0f;
    frames[f].variance.at(x, 10, 0) = 1.0f;
  }
  const Image out = denoise::temporal_filter(views(frames), 2);
  // Weights 1 / (var + the least var + (0.05 median)^2): the spike's is under 1/1000 of the
  // others' (median value under 0.8).
  EXPECT_NEAR(out.at(10, 10, 0), frames[2].truth.at(10, 10, 0), 0.01f);
  EXPECT_NEAR(out.at(30, 10, 0), frames[2].truth.at(30, 10, 0), 0.01f);
}

TEST(TemporalFilter, RefusesFramesOfAnotherSizeAndAMissingCentre) {
  std::vector<Frame> frames = {render_frame({}, 0.0f, 0.0f, 1), render_frame({}, 0.0f, 0.0f, 2)};
  std::vector<denoise::TemporalFrame> v = views(frames);
  EXPECT_THROW(denoise::temporal_filter(v, 2), Error);
  const Image small(8, 8, 1, 0.0f);
  v[1].depth = &small;
  EXPECT_THROW(denoise::temporal_filter(v, 0), Error);
  v[1].depth = nullptr;
  EXPECT_THROW(denoise::temporal_filter(v, 0), Error);
}

}  // namespace
