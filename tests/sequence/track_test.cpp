// Keyframe interpolation against values computed by hand from the glTF 2.0 specification
// (Appendix C): STEP, LINEAR (slerp for rotations) and CUBICSPLINE.
#include <gtest/gtest.h>

#include <cmath>

#include <glm/gtc/quaternion.hpp>

#include "dofcache/core/error.h"
#include "dofcache/sequence/track.h"

using namespace dofcache;
using namespace dofcache::sequence;

namespace {

constexpr double kPi = 3.14159265358979323846;

glm::dquat axis_angle(double degrees, glm::dvec3 axis) {
  double h = 0.5 * degrees * kPi / 180.0;
  axis = glm::normalize(axis);
  return glm::dquat(std::cos(h), axis.x * std::sin(h), axis.y * std::sin(h), axis.z * std::sin(h));
}

void expect_same_rotation(const glm::dquat& a, const glm::dquat& b) {
  double d = std::abs(a.x * b.x + a.y * b.y + a.z * b.z + a.w * b.w);  // q and -q are one rotation
  EXPECT_NEAR(d, 1.0, 1e-12) << "(" << a.w << " " << a.x << " " << a.y << " " << a.z << ") vs ("
                             << b.w << " " << b.x << " " << b.y << " " << b.z << ")";
}

TEST(Track, StepHoldsEachKeyUntilTheNext) {
  Track<glm::dvec3> t;
  t.interpolation = Interpolation::Step;
  t.times = {0.0, 1.0, 3.0};
  t.values = {{0, 0, 0}, {1, 2, 3}, {5, 5, 5}};
  t.validate("test");
  EXPECT_EQ(t.at(-1.0), glm::dvec3(0, 0, 0));  // before the first key: the first value
  EXPECT_EQ(t.at(0.999), glm::dvec3(0, 0, 0));
  EXPECT_EQ(t.at(1.0), glm::dvec3(1, 2, 3));
  EXPECT_EQ(t.at(2.9), glm::dvec3(1, 2, 3));
  EXPECT_EQ(t.at(3.0), glm::dvec3(5, 5, 5));
  EXPECT_EQ(t.at(9.0), glm::dvec3(5, 5, 5));  // after the last key: the last value
}

TEST(Track, LinearInterpolatesVectorsAndScalars) {
  Track<glm::dvec3> t;
  t.times = {1.0, 3.0};
  t.values = {{0, 0, 0}, {2, -4, 8}};
  // t = 1.5: s = (1.5 - 1) / 2 = 0.25
  glm::dvec3 v = t.at(1.5);
  EXPECT_DOUBLE_EQ(v.x, 0.5);
  EXPECT_DOUBLE_EQ(v.y, -1.0);
  EXPECT_DOUBLE_EQ(v.z, 2.0);

  Track<double> f;  // a focus pull from 1 m to 3 m over two seconds
  f.times = {0.0, 2.0};
  f.values = {1.0, 3.0};
  EXPECT_DOUBLE_EQ(f.at(0.5), 1.5);
  EXPECT_DOUBLE_EQ(f.at(2.0), 3.0);
}

TEST(Track, LinearRotationIsSlerpAlongTheShortArc) {
  Track<glm::dquat> t;
  t.times = {0.0, 1.0};
  t.values = {glm::dquat(1, 0, 0, 0), axis_angle(90.0, {0, 1, 0})};
  t.validate("test");
  expect_same_rotation(t.at(0.5), axis_angle(45.0, {0, 1, 0}));
  expect_same_rotation(t.at(0.25), axis_angle(22.5, {0, 1, 0}));
  // The second key stored as -q (the same rotation): slerp must not go the long way round.
  t.values[1] = -t.values[1];
  expect_same_rotation(t.at(0.5), axis_angle(45.0, {0, 1, 0}));
}

TEST(Track, CubicSplineIsTheHermiteOfTheSpecification) {
  // Keys at t = 0 and t = 2 (td = 2): v0 = (0,0,0) with out-tangent b0 = (1,0,0),
  // v1 = (1,0,0) with in-tangent a1 = (0,0,0). At t = 1, s = 0.5:
  //   p = (2s^3 - 3s^2 + 1) v0 + td (s^3 - 2s^2 + s) b0 + (-2s^3 + 3s^2) v1 + td (s^3 - s^2) a1
  //     = 0 + 2 * 0.125 * 1 + 0.5 * 1 + 0 = 0.75
  Track<glm::dvec3> t;
  t.interpolation = Interpolation::CubicSpline;
  t.times = {0.0, 2.0};
  t.values = {{9, 9, 9}, {0, 0, 0}, {1, 0, 0},    // key 0: in-tangent (unused), value, out-tangent
              {0, 0, 0}, {1, 0, 0}, {7, 7, 7}};   // key 1: in-tangent, value, out-tangent (unused)
  t.validate("test");
  EXPECT_DOUBLE_EQ(t.at(1.0).x, 0.75);
  EXPECT_DOUBLE_EQ(t.at(0.0).x, 0.0);
  EXPECT_DOUBLE_EQ(t.at(2.0).x, 1.0);
  // s = 0.25 (t = 0.5): 2 * (1/64 - 1/8 + 1/4) + (-2/64 + 3/16) = 0.28125 + 0.15625 = 0.4375
  EXPECT_DOUBLE_EQ(t.at(0.5).x, 0.4375);
}

TEST(Track, CubicSplineRotationIsNormalised) {
  Track<glm::dquat> t;
  t.interpolation = Interpolation::CubicSpline;
  t.times = {0.0, 1.0};
  glm::dquat zero(0, 0, 0, 0);
  t.values = {zero, glm::dquat(1, 0, 0, 0), zero, zero, axis_angle(90.0, {1, 0, 0}), zero};
  t.validate("test");
  // Zero tangents: the Hermite weights at s = 0.5 are 1/2 and 1/2, so the result is the
  // normalised sum, i.e. the 45-degree rotation.
  glm::dquat q = t.at(0.5);
  EXPECT_NEAR(glm::length(q), 1.0, 1e-12);
  expect_same_rotation(q, axis_angle(45.0, {1, 0, 0}));
}

TEST(Track, ValidationNamesTheProblem) {
  Track<double> t;
  t.times = {0.0, 0.0};
  t.values = {1.0, 2.0};
  EXPECT_THROW(t.validate("x"), Error);
  t.times = {0.0, 1.0};
  t.values = {1.0};
  EXPECT_THROW(t.validate("x"), Error);
  t.values = {1.0, NAN};
  EXPECT_THROW(t.validate("x"), Error);
  EXPECT_EQ(parse_interpolation("cubicspline", "x"), Interpolation::CubicSpline);
  EXPECT_THROW(parse_interpolation("BEZIER", "x"), Error);
}

}  // namespace
