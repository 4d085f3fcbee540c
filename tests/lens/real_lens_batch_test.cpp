// Real lenses traced several rays at a time (RealLens::sample_n) against one at a time
// (RealLens::sample): every output bit for bit the same, for each shipped lens wide open and at
// f/8, through a round and a six-blade stop, in every colour band, at the film's centre, edges and
// corners, for the rays the lens passes and for those it stops (their origin and direction where
// they stopped).
#include "dofcache/lens/real_lens.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

namespace dofcache::lens {
namespace {

// The shipped lenses, and the double Gauss with Abbe numbers (glasses of its indices: barium
// flint, dense flint, flint, dense crown, lanthanum flint), whose colour bands differ.
const char* const kLenses[] = {"double_gauss_50mm", "wide_28mm", "telephoto_250mm",
                               "fisheye_10mm", "dispersive double Gauss", "thick plano-convex"};

std::shared_ptr<const LensSystem> lens_system(const std::string& name) {
  if (name == "thick plano-convex")
    return std::make_shared<const LensSystem>(LensSystem::parse("0 2 0 10\n"
                                                                "0 8 1.8 12\n"
                                                                "-6 0 1 11.9\n",
                                                                name));
  if (name != "dispersive double Gauss") return read_lens_file(name);
  return std::make_shared<const LensSystem>(LensSystem::parse("29.475 3.76 1.670 25.2 47.2\n"
                                                              "84.83 0.12 1 25.2\n"
                                                              "19.275 4.025 1.670 23.0 47.2\n"
                                                              "40.77 3.275 1.699 23.0 30.1\n"
                                                              "12.75 5.705 1 18.0\n"
                                                              "0 4.5 0 17.1\n"
                                                              "-14.495 1.18 1.603 17.0 38.0\n"
                                                              "40.77 6.065 1.658 20.0 57.3\n"
                                                              "-20.385 0.19 1 20.0\n"
                                                              "437.065 3.22 1.717 20.0 48.0\n"
                                                              "-39.73 0 1 20.0\n",
                                                              name));
}

std::uint64_t bits(double v) {
  std::uint64_t b;
  std::memcpy(&b, &v, sizeof b);
  return b;
}

// Bit for bit (== would take -0 for 0 and miss a NaN).
bool same(const RealLens::Sample& a, const RealLens::Sample& b) {
  for (int i = 0; i < 3; ++i)
    if (bits(a.ray.origin[i]) != bits(b.ray.origin[i]) ||
        bits(a.ray.direction[i]) != bits(b.ray.direction[i]))
      return false;
  return bits(a.weight) == bits(b.weight);
}

std::string describe(const RealLens::Sample& s) {
  char text[200];
  std::snprintf(text, sizeof text, "origin (%.17g, %.17g, %.17g) direction (%.17g, %.17g, %.17g) "
                "weight %.17g", s.ray.origin.x, s.ray.origin.y, s.ray.origin.z, s.ray.direction.x,
                s.ray.direction.y, s.ray.direction.z, s.weight);
  return text;
}

// Film points: the centre, the 36 x 24 mm frame's corners and edge midpoints, just beyond the
// film's radius, and a spread over the frame; lens points: the pupil bounds' corners and centre,
// and a spread. Each film point with each lens point, the bands in turn, so that the lanes of
// one group differ in film point, lens point and band.
struct Inputs {
  std::vector<glm::dvec2> film, u;
  std::vector<int> band;
};

Inputs inputs() {
  std::vector<glm::dvec2> films = {{0.0, 0.0}, {0.018, 0.012}, {-0.018, 0.012}, {0.018, -0.012},
                                   {-0.018, -0.012}, {0.018, 0.0}, {0.0, -0.012}, {0.0217, 0.0},
                                   {1e-9, 0.0}};
  std::vector<glm::dvec2> us = {{0.0, 0.0}, {0.999999, 0.999999}, {0.0, 0.999999},
                                {0.999999, 0.0}, {0.5, 0.5}};
  std::uint32_t state = 12345u;
  auto next = [&] {
    state = state * 1664525u + 1013904223u;
    return (state >> 8) * 0x1p-24;
  };
  for (int i = 0; i < 40; ++i) films.push_back({(next() - 0.5) * 0.036, (next() - 0.5) * 0.024});
  for (int i = 0; i < 11; ++i) us.push_back({next(), next()});
  Inputs in;
  int k = 0;
  for (const glm::dvec2& f : films)
    for (const glm::dvec2& u : us) {
      in.film.push_back(f), in.u.push_back(u);
      in.band.push_back(k++ % 5 - 1);  // -1, 0, 1, 2 and 3 (out of range: as -1)
    }
  // Three short of a multiple of eight: groups of eight, one of four and one sample alone.
  const std::size_t n = in.film.size() - 3;
  in.film.resize(n), in.u.resize(n), in.band.resize(n);
  return in;
}

struct Counts {
  int passed = 0, stopped_in_lens = 0;
};

// sample_n against sample() over `in`; counts the rays that pass and those stopped after they
// entered the rear element (a stopped lane's state is its own).
Counts expect_batch_is_scalar(const RealLens& lens, const Inputs& in) {
  const std::size_t n = in.film.size();
  std::vector<RealLens::Sample> batch(n);
  lens.sample_n(n, in.film.data(), in.u.data(), in.band.data(), batch.data());
  Counts c;
  int mismatches = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const RealLens::Sample one = lens.sample(in.film[i], in.u[i], in.band[i]);
    if (!same(batch[i], one) && ++mismatches <= 5)
      ADD_FAILURE() << "sample " << i << " (band "
                    << in.band[i] << "): batch " << describe(batch[i]) << "; one by one "
                    << describe(one);
    if (one.weight > 0.0) ++c.passed;
    else if (one.ray.origin.z > 0.0) ++c.stopped_in_lens;
  }
  EXPECT_EQ(mismatches, 0);
  return c;
}

TEST(RealLensBatch, EverySampleIsTheScalarSamplesBitForBit) {
  const Inputs in = inputs();
  for (const char* name : kLenses)
    for (double fstop : {0.0, 8.0})
      for (int blades : {0, 6}) {
        SCOPED_TRACE(std::string(name) + " f/" + std::to_string(fstop) + " blades " +
                     std::to_string(blades));
        RealLensSettings settings;
        settings.fstop = fstop, settings.focus_distance = 3.0;
        if (blades) settings.stop_shape = ApertureShape(blades, 15.0, 0.0, 1.0);
        const RealLens lens(*lens_system(name), settings);
        const Counts c = expect_batch_is_scalar(lens, in);
        // Both kinds of ray are compared: passed, and stopped inside the lens.
        EXPECT_GT(c.passed, 0);
        EXPECT_GT(c.stopped_in_lens, 0);
      }
}

TEST(RealLensBatch, HoldsWithTheExposureFollowingTheLensAndAnAnamorphicStop) {
  const Inputs in = inputs();
  RealLensSettings settings;
  settings.fstop = 4.0, settings.focus_distance = 1.0, settings.exposure_follows_lens = true;
  settings.stop_shape = ApertureShape(0, 0.0, 0.0, 2.0);
  const RealLens lens(*read_lens_file("double_gauss_50mm"), settings);
  const Counts c = expect_batch_is_scalar(lens, in);
  EXPECT_GT(c.passed, 0);
}

// A lane mixed up with another would give it the other's ray: the lanes of a group here differ
// in everything, and each must be its own, in a group of eight and in one of four.
TEST(RealLensBatch, EachLaneIsItsOwnRay) {
  const RealLens lens(*lens_system("dispersive double Gauss"), {});
  ASSERT_TRUE(lens.dispersive());
  const glm::dvec2 film[8] = {{0.0, 0.0},     {0.01, 0.005},   {-0.015, 0.01}, {0.005, -0.012},
                              {-0.002, 0.003}, {0.012, -0.004}, {0.0, 0.011},   {-0.009, -0.009}};
  const glm::dvec2 u[8] = {{0.5, 0.5}, {0.3, 0.6},  {0.7, 0.2},   {0.45, 0.55},
                           {0.6, 0.4}, {0.35, 0.5}, {0.55, 0.65}, {0.4, 0.45}};
  const int band[8] = {-1, 0, 1, 2, 2, 1, 0, -1};
  for (int n : {8, 4}) {
    SCOPED_TRACE(n);
    RealLens::Sample batch[8];
    lens.sample_n(n, film, u, band, batch);
    for (int i = 0; i < n; ++i) {
      SCOPED_TRACE(i);
      EXPECT_GT(batch[i].weight, 0.0);
      EXPECT_TRUE(same(batch[i], lens.sample(film[i], u[i], band[i])));
      for (int j = 0; j < i; ++j) EXPECT_FALSE(same(batch[i], batch[j]));
    }
    // The same inputs in the reverse order give the same rays in the reverse order.
    glm::dvec2 rfilm[8], ru[8];
    int rband[8];
    for (int i = 0; i < n; ++i)
      rfilm[i] = film[n - 1 - i], ru[i] = u[n - 1 - i], rband[i] = band[n - 1 - i];
    RealLens::Sample reversed[8];
    lens.sample_n(n, rfilm, ru, rband, reversed);
    for (int i = 0; i < n; ++i) EXPECT_TRUE(same(reversed[i], batch[n - 1 - i]));
  }
  // The bands differ: the same film and lens point in another band is another ray.
  RealLens::Sample blue[1];
  const int band2[1] = {2};
  lens.sample_n(1, &film[1], &u[1], band2, blue);
  EXPECT_GT(blue[0].weight, 0.0);
  EXPECT_TRUE(same(blue[0], lens.sample(film[1], u[1], 2)));
  EXPECT_FALSE(same(blue[0], lens.sample(film[1], u[1], 0)));
}

TEST(RealLensBatch, FewerSamplesThanLanesAndNoneAtAll) {
  const RealLens lens(*read_lens_file("wide_28mm"), {});
  const glm::dvec2 film[3] = {{0.0, 0.0}, {0.01, 0.005}, {-0.015, 0.01}};
  const glm::dvec2 u[3] = {{0.5, 0.5}, {0.3, 0.6}, {0.7, 0.2}};
  const int band[3] = {-1, 1, 2};
  RealLens::Sample out[3];
  lens.sample_n(3, film, u, band, out);
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(same(out[i], lens.sample(film[i], u[i], band[i])));
  lens.sample_n(0, film, u, band, out);  // nothing to do
}

}  // namespace
}  // namespace dofcache::lens
