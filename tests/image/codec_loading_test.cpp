// The image codecs (OpenImageIO and the ~260 libraries it links) are loaded on first use, not at
// program start (src/image/codec_module.h): a program that never touches an image file never
// pays for them, and one that does gets them transparently.
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "dofcache/core/error.h"
#include "dofcache/image/image_io.h"
#include "scratch_dir.h"

namespace dofcache::image {
namespace {

// Whether a shared object whose file name contains `name` is mapped into this process.
bool mapped(const std::string& name) {
  std::ifstream maps("/proc/self/maps");
  std::string line;
  while (std::getline(maps, line))
    if (line.find(name) != std::string::npos) return true;
  return false;
}

class CodecLoading : public dofcache::testing::ScratchDirTest {};

// One test, in its own process: the order of the two observations matters.
TEST_F(CodecLoading, OpenImageIoIsLoadedByTheFirstImageWriteNotBefore) {
  EXPECT_FALSE(mapped("libOpenImageIO")) << "the image library links OpenImageIO again";
  EXPECT_FALSE(mapped("libdofcache_image_codec"));

  Image red(2, 1, 3, 0.0f);
  red.pixel(0, 0)[0] = red.pixel(1, 0)[0] = 1.0f;
  const std::string file = path("red.png");
  write_image(file, red);
  EXPECT_TRUE(mapped("libdofcache_image_codec"));
  EXPECT_TRUE(mapped("libOpenImageIO"));

  const Image back = read_image(file);
  ASSERT_EQ(back.width(), 2);
  EXPECT_NEAR(back.pixel(1, 0)[0], 1.0f, 1e-6f);  // sRGB 255 decodes to exactly 1
  EXPECT_NEAR(back.pixel(1, 0)[1], 0.0f, 1e-6f);
}

// Paths are checked without the codecs, so a bad output path is refused before a render.
TEST_F(CodecLoading, BadOutputPathIsRefusedInOneLine) {
  try {
    check_output_path(path("missing/dir/out.png"));
    FAIL() << "no error";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("does not exist"), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos);
  }
}

}  // namespace
}  // namespace dofcache::image
