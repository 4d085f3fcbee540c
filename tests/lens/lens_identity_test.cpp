// The lens a cache file records (lens/lens_identity.h): the design is the optics mounted (thin
// lens or prescription, the stop's shape and every aberration), not the settings a camera path
// moves (focal length, f-number, focus); the description names every parameter.
#include <gtest/gtest.h>

#include "scratch_dir.h"

#include <fstream>

#include "dofcache/core/error.h"
#include "dofcache/lens/lens_identity.h"
#include "dofcache/lens/real_lens.h"

using namespace dofcache;
using namespace dofcache::lens;

namespace {

class LensIdentityTest : public dofcache::testing::ScratchDirTest {};

ThinLens thin(const ApertureShape& a = {}) { return ThinLens(0.05, 2.8, 3.0, a); }

MountedLens mounted(const std::string& name, double fstop, double focus,
                    const ApertureShape& stop = {}) {
  return mount_lens(read_lens_file(name), name, fstop, focus, Sensor{}, 300, 200, false, stop);
}

TEST_F(LensIdentityTest, SettingsAreNotTheDesign) {
  const std::uint64_t round = lens_design(thin());
  EXPECT_NE(round, 0u);
  EXPECT_EQ(lens_design(ThinLens(0.085, 1.4, 12.0)), round);  // zoom, aperture pulled, refocused
  // Every shape feature is a design of its own.
  ApertureShape a;
  std::vector<ApertureShape> shapes;
  a = {}, a.blades = 6, shapes.push_back(a);
  a.rotation_deg = 20, shapes.push_back(a);
  a.roundness = 0.5, shapes.push_back(a);
  a = {}, a.anamorphic_ratio = 2.0, shapes.push_back(a);
  a = {}, a.stop = {0.02, 0.05}, shapes.push_back(a);
  a = {}, a.axial_ca = 0.001, shapes.push_back(a);
  a = {}, a.lateral_ca = 0.01, shapes.push_back(a);
  a = {}, a.profile = ApertureProfile::Rim, shapes.push_back(a);
  a.profile_strength = 0.5, shapes.push_back(a);
  a = {}, a.tilt_x_deg = 5, shapes.push_back(a);
  a = {}, a.shift_y = 0.1, shapes.push_back(a);
  std::vector<std::uint64_t> designs{round};
  for (const ApertureShape& s : shapes) {
    const std::uint64_t d = lens_design(thin(s));
    for (std::uint64_t seen : designs) EXPECT_NE(d, seen) << describe_aperture(s);
    designs.push_back(d);
  }
}

TEST_F(LensIdentityTest, AnApertureImageIsItsBytes) {
  std::ofstream(path("a.pgm"), std::ios::binary) << "P2 2 1 255 0 255\n";
  std::ofstream(path("copy.pgm"), std::ios::binary) << "P2 2 1 255 0 255\n";
  std::ofstream(path("other.pgm"), std::ios::binary) << "P2 2 1 255 255 0\n";
  ApertureShape a, copy, other;
  a.image = path("a.pgm"), copy.image = path("copy.pgm"), other.image = path("other.pgm");
  EXPECT_EQ(lens_design(thin(a)), lens_design(thin(copy)));  // a farm node's copy
  EXPECT_NE(lens_design(thin(a)), lens_design(thin(other)));
  EXPECT_NE(lens_design(thin(a)), lens_design(thin()));
  ApertureShape missing;
  missing.image = path("missing.pgm");
  EXPECT_THROW(lens_design(thin(missing)), Error);
}

TEST_F(LensIdentityTest, APrescriptionIsItsGlassAndItsStop) {
  const MountedLens gauss = mounted("double_gauss_50mm", 2.8, 3.0);
  const std::uint64_t d = lens_design(gauss.equivalent(), gauss);
  // Refocused and stopped down: the same lens.
  const MountedLens moved = mounted("double_gauss_50mm", 8.0, 0.8);
  EXPECT_EQ(lens_design(moved.equivalent(), moved), d);
  // Another prescription, the thin lens, or the same glass behind six blades: other designs.
  const MountedLens wide = mounted("wide_28mm", 2.8, 3.0);
  EXPECT_NE(lens_design(wide.equivalent(), wide), d);
  EXPECT_NE(lens_design(gauss.equivalent()), d);
  ApertureShape six;
  six.blades = 6;
  const MountedLens bladed = mounted("double_gauss_50mm", 2.8, 3.0, six);
  EXPECT_NE(lens_design(bladed.equivalent(), bladed), d);
}

TEST_F(LensIdentityTest, TheDescriptionNamesEveryParameter) {
  ApertureShape a;
  a.blades = 6, a.rotation_deg = 20, a.anamorphic_ratio = 2;
  EXPECT_EQ(describe_aperture(a), "6 blades, a corner at 20 deg, roundness 0, anamorphic ratio 2");
  EXPECT_EQ(describe_lens(ThinLens(0.05, 2.8, 3.0, a)),
            "thin lens 50 mm, f/2.8, focus 3 m, aperture 6 blades, a corner at 20 deg, "
            "roundness 0, anamorphic ratio 2");
  const MountedLens gauss = mounted("double_gauss_50mm", 4.0, 2.5);
  const std::string text = describe_lens(gauss.equivalent(), gauss);
  EXPECT_NE(text.find("lens double_gauss_50mm ("), std::string::npos) << text;
  EXPECT_NE(text.find("f/4, focus 2.5 m from the sensor, aperture round"), std::string::npos)
      << text;
  const LensIdentity id = lens_identity(gauss.equivalent(), gauss);
  EXPECT_EQ(id.description, text);
  EXPECT_EQ(id.design, lens_design(gauss.equivalent(), gauss));
}

}  // namespace
