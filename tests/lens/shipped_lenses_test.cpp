// The prescriptions built into the program are scenes/lenses/'s files, byte for byte, found by
// their names where no file of that name exists.
#include "dofcache/lens/shipped_lenses.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "dofcache/core/error.h"
#include "dofcache/lens/real_lens.h"

namespace dofcache::lens {
namespace {

const std::filesystem::path kDir = std::filesystem::path(DOFCACHE_SOURCE_DIR) / "scenes" / "lenses";

TEST(ShippedLenses, AreTheFilesOfScenesLenses) {
  std::vector<std::string> files;
  for (const auto& entry : std::filesystem::directory_iterator(kDir))
    if (entry.path().extension() == ".lens") files.push_back(entry.path().stem().string());
  std::sort(files.begin(), files.end());
  ASSERT_EQ(shipped_lenses().size(), files.size());
  for (std::size_t i = 0; i < files.size(); ++i) {
    const ShippedLens& l = shipped_lenses()[i];
    EXPECT_EQ(l.name, files[i]);
    std::ifstream in(kDir / (files[i] + ".lens"), std::ios::binary);
    std::stringstream text;
    text << in.rdbuf();
    EXPECT_EQ(l.table, text.str()) << files[i];
  }
  EXPECT_GE(files.size(), 4u);  // the four: a double Gauss, a wide angle, a tele, a fisheye
}

TEST(ShippedLenses, AreFoundByNameWhereNoFileIs) {
  ASSERT_NE(find_shipped_lens("double_gauss_50mm"), nullptr);
  EXPECT_EQ(find_shipped_lens("double_gauss_50mm.lens"), find_shipped_lens("double_gauss_50mm"));
  EXPECT_EQ(find_shipped_lens("elsewhere/double_gauss_50mm.lens"), nullptr);  // a path: a file
  EXPECT_EQ(find_shipped_lens("double_gauss"), nullptr);
  // The built-in table reads as the file does.
  const auto built_in = read_lens_file("double_gauss_50mm");
  const LensSystem file = LensSystem::read((kDir / "double_gauss_50mm.lens").string());
  ASSERT_EQ(built_in->surfaces().size(), file.surfaces().size());
  EXPECT_DOUBLE_EQ(built_in->effective_focal_length(), file.effective_focal_length());
  try {
    read_lens_file("no_such_lens");
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("cannot read the lens file no_such_lens"), std::string::npos) << m;
    EXPECT_NE(m.find("nor is it a shipped lens: double_gauss_50mm"), std::string::npos) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos);
  }
}

}  // namespace
}  // namespace dofcache::lens
