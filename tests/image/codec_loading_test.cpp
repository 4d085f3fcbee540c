// The image codecs (OpenImageIO and the ~260 libraries it links) are loaded on first use, not at
// program start (src/image/codec_module.h): a program that only writes images (PNG, EXR) never
// pays for them, and one that reads them gets them transparently.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <limits>
#include <vector>
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

// One test, in its own process: the order of the observations matters.
TEST_F(CodecLoading, OpenImageIoIsLoadedByTheFirstImageReadNotByPngOrExrWrites) {
  EXPECT_FALSE(mapped("libOpenImageIO")) << "the image library links OpenImageIO again";
  EXPECT_FALSE(mapped("libdofcache_image_codec"));

  // A PNG is encoded by the image library itself.
  Image red(2, 1, 3, 0.0f);
  red.pixel(0, 0)[0] = red.pixel(1, 0)[0] = 1.0f;
  red.pixel(0, 0)[1] = 0.5f;  // sRGB: 255 * (1.055 * 0.5^(1/2.4) - 0.055) = 187.5 -> 188
  const std::string file = path("red.png");
  write_image(file, red);
  EXPECT_FALSE(mapped("libdofcache_image_codec"));
  EXPECT_FALSE(mapped("libOpenImageIO"));

  // So is an EXR, extra channels included (OpenEXR, linked).
  Image depth(2, 1, 1, 0.0f);
  depth.pixel(0, 0)[0] = 2.5f;
  depth.pixel(1, 0)[0] = 1e30f;
  write_image(path("red.exr"), red, {{{"Z"}, depth}});
  EXPECT_FALSE(mapped("libdofcache_image_codec"));
  EXPECT_FALSE(mapped("libOpenImageIO"));

  // Reading it back (OpenImageIO's PNG reader: an independent decoder) loads the codecs.
  const Image back = read_image(file);
  EXPECT_TRUE(mapped("libdofcache_image_codec"));
  EXPECT_TRUE(mapped("libOpenImageIO"));
  ASSERT_EQ(back.width(), 2);
  ASSERT_EQ(back.height(), 1);
  EXPECT_NEAR(back.pixel(1, 0)[0], 1.0f, 1e-6f);  // sRGB 255 decodes to exactly 1
  EXPECT_NEAR(back.pixel(1, 0)[1], 0.0f, 1e-6f);
  EXPECT_NEAR(back.pixel(0, 0)[1], srgb_to_linear(188.0f / 255.0f), 1e-6f);

  // And OpenImageIO's EXR reader (OpenEXR again, but through its own code) gets the floats back.
  const Image exr = read_image(path("red.exr"));
  ASSERT_TRUE(exr.same_shape(red));
  EXPECT_EQ(exr.data(), red.data());
  const Image z = read_channels(path("red.exr"), {"Z"});
  EXPECT_EQ(z.data(), depth.data());
}

// A program that preloads waits for the load before it exits (src/cli/main.cpp): finishing is a
// no-op without a preload, and after one it returns only once the libraries are in. In its own
// process, like the test above.
TEST_F(CodecLoading, FinishingWaitsForAPreloadAndLoadsNothingWithoutOne) {
  finish_loading_image_codecs();
  EXPECT_FALSE(mapped("libdofcache_image_codec"));
  EXPECT_FALSE(mapped("libOpenImageIO"));
  preload_image_codecs();
  finish_loading_image_codecs();  // the load takes about 0.4 s: without the wait, not yet mapped
  EXPECT_TRUE(mapped("libdofcache_image_codec"));
  EXPECT_TRUE(mapped("libOpenImageIO"));
}

// The in-memory PNG is a complete file: the same bytes as the written one.
TEST_F(CodecLoading, EncodedPngEqualsTheWrittenFile) {
  Image img(3, 2, 3, 0.25f);
  img.pixel(2, 1)[2] = std::numeric_limits<float>::quiet_NaN();  // written as 0
  const std::vector<unsigned char> bytes = encode_png(img);
  ASSERT_GT(bytes.size(), 8u);
  EXPECT_EQ(std::string(bytes.begin() + 1, bytes.begin() + 4), "PNG");
  write_image(path("grey.png"), img);
  std::ifstream in(path("grey.png"), std::ios::binary);
  const std::vector<unsigned char> file((std::istreambuf_iterator<char>(in)),
                                        std::istreambuf_iterator<char>());
  EXPECT_EQ(file, bytes);
  const Image back = read_image(path("grey.png"));
  EXPECT_NEAR(back.pixel(0, 0)[0], srgb_to_linear(std::round(linear_to_srgb(0.25f) * 255.0f) / 255.0f),
              1e-6f);
  EXPECT_EQ(back.pixel(2, 1)[2], 0.0f);
}

// The in-memory EXR is a complete file: the same bytes as the written one.
TEST_F(CodecLoading, EncodedExrEqualsTheWrittenFile) {
  Image img(3, 2, 3, 0.25f);
  img.pixel(2, 1)[2] = -7.5f;
  const std::vector<unsigned char> bytes = encode_exr(img);
  ASSERT_GT(bytes.size(), 4u);
  EXPECT_EQ(std::vector<unsigned char>(bytes.begin(), bytes.begin() + 4),
            (std::vector<unsigned char>{0x76, 0x2f, 0x31, 0x01}));  // EXR magic number
  write_image(path("grey.exr"), img);
  std::ifstream in(path("grey.exr"), std::ios::binary);
  const std::vector<unsigned char> file((std::istreambuf_iterator<char>(in)),
                                        std::istreambuf_iterator<char>());
  EXPECT_EQ(file, bytes);
  EXPECT_THROW(encode_exr(Image(3, 2, 1)), Error);  // not RGB
  EXPECT_THROW(encode_exr(Image()), Error);
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
