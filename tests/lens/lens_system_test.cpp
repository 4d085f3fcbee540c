// Lens prescriptions: the table reader and its paraxial optics against thick-lens formulas worked
// by hand.
#include "dofcache/lens/lens_system.h"

#include <gtest/gtest.h>

#include <string>

#include "dofcache/core/error.h"

namespace dofcache::lens {
namespace {

// A biconvex lens, R1 = 50 mm, R2 = -50 mm, 10 mm thick, n = 1.5, in air. Lensmaker's equation
// for a thick lens: 1 / f = (n - 1) (1 / R1 - 1 / R2 + (n - 1) d / (n R1 R2))
// = 0.5 (0.02 + 0.02 - 5 / 3750) = 0.0193333 / mm, f = 51.7241 mm; the back focal distance
// f (1 - (n - 1) d / (n R1)) = 51.7241 x (1 - 1 / 15) = 48.2759 mm.
TEST(LensSystem, ThickBiconvexLensHasTheLensmakersFocalLength) {
  const LensSystem s = LensSystem::parse("# R  t  n  aperture\n"
                                         "50   10  1.5  20\n"
                                         "\n"
                                         "-50  48.2759  1  20   # to the film\n",
                                         "biconvex");
  ASSERT_EQ(s.surfaces().size(), 2u);
  EXPECT_DOUBLE_EQ(s.surfaces()[0].radius, 0.05);
  EXPECT_DOUBLE_EQ(s.surfaces()[0].ior, 1.5);
  EXPECT_EQ(s.stop_index(), -1);
  EXPECT_NEAR(s.effective_focal_length(), 0.0517241, 1e-7);
  EXPECT_NEAR(s.back_focal_distance(), 0.0482759, 1e-7);
}

// Plano-convex, curved side first: f = R / (n - 1) = 200 mm whatever the thickness; the back focal
// distance is f - d / n = 200 - 5 / 1.5 = 196.667 mm. A stop row (radius 0, index 0) in front is
// flat air: it changes neither, and is found as the stop.
TEST(LensSystem, PlanoConvexLensAndTheStopRow) {
  const LensSystem s = LensSystem::parse("0 10 0 12\n100 5 1.5 30 64.2\n0 196.667 1 30\n", "plano");
  ASSERT_EQ(s.surfaces().size(), 3u);
  EXPECT_EQ(s.stop_index(), 0);
  EXPECT_TRUE(s.surfaces()[0].stop);
  EXPECT_DOUBLE_EQ(s.surfaces()[0].ior, 1.0);
  EXPECT_DOUBLE_EQ(s.surfaces()[1].abbe, 64.2);
  EXPECT_NEAR(s.effective_focal_length(), 0.2, 1e-9);
  EXPECT_NEAR(s.back_focal_distance(), 0.196667, 1e-6);
}

TEST(LensSystem, BadTablesAreOneLineErrorsNamingTheLine) {
  auto message = [](const std::string& text) {
    try {
      LensSystem::parse(text, "t.dat");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  const std::pair<const char*, const char*> cases[] = {
      {"50 10 1.5 20\n-50 abc 1 20\n", "line 2: 'abc' is not a number"},
      {"50 10 1.5\n", "expected 4 or 5 numbers"},
      {"50 -1 1.5 20\n", "negative thickness"},
      {"50 1 0.5 20\n", "index of refraction"},
      {"50 1 1.5 0\n", "aperture diameter must be positive"},
      {"5 1 1.5 20\n", "smaller than half"},
      {"0 1 0 20\n0 1 0 20\n", "second aperture stop"},
      {"# nothing\n\n", "no surfaces"},
      {"50 1 1.5 20 -3\n", "negative Abbe"},
      {"1e300 1 1.5 20\n", "beyond 10 km"},
      {"50 nan 1.5 20\n", "not a number"},
  };
  for (const auto& [text, expected] : cases) {
    const std::string m = message(text);
    EXPECT_NE(m.find(expected), std::string::npos) << text << " -> " << m;
    EXPECT_NE(m.find("t.dat"), std::string::npos) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  }
  EXPECT_THROW(LensSystem::read("/nonexistent/lens.dat"), Error);
  // Flat glass only: afocal.
  EXPECT_THROW(LensSystem::parse("0 5 1.5 20\n0 10 1 20\n", "flat").effective_focal_length(),
               Error);
}

}  // namespace
}  // namespace dofcache::lens
