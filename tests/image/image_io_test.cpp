// Image files: exact EXR round trips (single- and multi-part), PNG through sRGB, atomic writes
// that leave nothing behind on failure, and one-line errors for bad input.
#include "dofcache/image/image_io.h"
#include "scratch_dir.h"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "dofcache/core/atomic_file.h"
#include "dofcache/core/error.h"

namespace dofcache::image {
namespace {

namespace fs = std::filesystem;

Image random_image(int w, int h, int c, unsigned seed, float lo, float hi) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(lo, hi);
  Image im(w, h, c);
  for (float& v : im.data()) v = u(rng);
  return im;
}

void expect_identical(const Image& a, const Image& b) {
  ASSERT_TRUE(a.same_shape(b)) << a.width() << "x" << a.height() << "x" << a.channels() << " vs "
                               << b.width() << "x" << b.height() << "x" << b.channels();
  for (size_t i = 0; i < a.data().size(); ++i)
    ASSERT_EQ(a.data()[i], b.data()[i]) << "at sample " << i;
}

// Runs `fn`, expecting a one-line dofcache::Error; returns its message.
template <class Fn>
std::string error_of(Fn&& fn) {
  try {
    fn();
  } catch (const Error& e) {
    std::string msg = e.what();
    EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
    return msg;
  }
  ADD_FAILURE() << "expected dofcache::Error";
  return {};
}

class ImageIo : public dofcache::testing::ScratchDirTest {
 protected:
  std::vector<std::string> listing() const {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(dir_))
      names.push_back(entry.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  }
};

TEST(Srgb, TransferFunctions) {
  EXPECT_EQ(linear_to_srgb(0.0f), 0.0f);
  EXPECT_EQ(linear_to_srgb(1.0f), 1.0f);
  EXPECT_NEAR(linear_to_srgb(0.5f), 0.735357f, 1e-5);
  EXPECT_NEAR(linear_to_srgb(0.002f), 0.02584f, 1e-6);  // linear segment, 12.92 x
  EXPECT_EQ(linear_to_srgb(-1.0f), 0.0f);
  EXPECT_EQ(linear_to_srgb(7.0f), 1.0f);
  EXPECT_EQ(linear_to_srgb(std::nanf("")), 0.0f);
  for (float v = 0.0f; v <= 1.0f; v += 0.01f)
    EXPECT_NEAR(srgb_to_linear(linear_to_srgb(v)), v, 1e-5);
}

TEST_F(ImageIo, ExrRoundTripIsExactWithExtraChannels) {
  Image color = random_image(13, 7, 3, 1, -2.0f, 1000.0f);  // HDR and negative values
  color.at(0, 0, 0) = 1e-30f;
  color.at(1, 0, 1) = 3.0e38f;
  NamedChannels depth{{"Z"}, random_image(13, 7, 1, 2, 0.1f, 1e4f)};
  NamedChannels normal{{"N.X", "N.Y", "N.Z"}, random_image(13, 7, 3, 3, -1.0f, 1.0f)};
  const std::string file = path("frame.exr");
  write_image(file, color, {depth, normal});
  EXPECT_EQ(listing(), std::vector<std::string>{"frame.exr"});  // no temporary left over

  expect_identical(read_image(file), color);
  expect_identical(read_channels(file, {"Z"}), depth.image);
  expect_identical(read_channels(file, {"N.X", "N.Y", "N.Z"}), normal.image);
  Image zx = read_channels(file, {"N.Z", "N.X"});  // any order asked for
  EXPECT_EQ(zx.at(4, 5, 0), normal.image.at(4, 5, 2));
  EXPECT_EQ(zx.at(4, 5, 1), normal.image.at(4, 5, 0));

  std::string msg = error_of([&] { read_channels(file, {"Q"}); });
  EXPECT_NE(msg.find("'Q'"), std::string::npos) << msg;
}

TEST_F(ImageIo, ExtensionIsCaseInsensitive) {
  Image color = random_image(4, 3, 3, 4, 0.0f, 1.0f);
  write_image(path("upper.EXR"), color);
  expect_identical(read_image(path("upper.EXR")), color);
  write_image(path("upper.Png"), color);
  EXPECT_EQ(read_image(path("upper.Png")).width(), 4);
}

TEST_F(ImageIo, PngRoundTripWithinOneStep) {
  Image color = random_image(16, 9, 3, 5, 0.0f, 1.0f);
  color.at(0, 0, 0) = -0.5f;  // clamped to 0
  color.at(1, 0, 1) = 3.0f;   // clamped to 1
  const std::string file = path("frame.png");
  write_image(file, color, {{{"Z"}, Image(16, 9, 1, 2.0f)}});  // extras are ignored by PNG
  Image back = read_image(file);
  ASSERT_TRUE(back.same_shape(color));
  for (size_t i = 0; i < color.data().size(); ++i) {
    // Compared as displayed: rounding to 8 bits moves a value by at most half a step.
    float want = linear_to_srgb(color.data()[i]);
    EXPECT_NEAR(linear_to_srgb(back.data()[i]), want, 0.5f / 255 + 1e-6f) << "sample " << i;
  }
  EXPECT_EQ(back.at(0, 0, 0), 0.0f);
  EXPECT_EQ(back.at(1, 0, 1), 1.0f);
}

TEST_F(ImageIo, PngStoresSrgbCodes) {
  // Linear 0.5 is sRGB 0.7354 -> code 188 (not 128, which a plain gamma-free write would give).
  const std::string file = path("half.png");
  write_image(file, Image(2, 2, 3, 0.5f));
  Image raw = read_channels(file, {"R"});  // read_channels does not decode
  EXPECT_NEAR(raw.at(0, 0, 0), 188.0f / 255.0f, 1e-6);
  EXPECT_NEAR(read_image(file).at(1, 1, 2), srgb_to_linear(188.0f / 255.0f), 1e-6);
}

// Files in other formats than dofcache writes: half-float channels beside a float one (read in
// their own formats and converted), and tiles (read through OpenImageIO's conversion).
TEST_F(ImageIo, HalfMixedAndTiledExrsReadExactly) {
  const std::vector<float> px = {0.5f, 1.25f, -3.0f, 2.0f, 0.0f, 65504.0f,
                                 0.125f, 7.0f, 1e-3f, 4.0f, 0.75f, 3.5f};  // 2x2 RGB
  auto write = [&](const std::string& file, bool mixed, bool tiled) {
    auto out = OIIO::ImageOutput::create(file);
    ASSERT_TRUE(out);
    OIIO::ImageSpec spec(2, 2, 3, OIIO::TypeDesc::HALF);
    if (mixed) spec.channelformats = {OIIO::TypeDesc::HALF, OIIO::TypeDesc::HALF, OIIO::TypeDesc::FLOAT};
    if (tiled) spec.tile_width = spec.tile_height = 16;
    spec.channelnames = {"R", "G", "B"};
    ASSERT_TRUE(out->open(file, spec));
    ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, px.data()));
    ASSERT_TRUE(out->close());
  };
  for (int variant = 0; variant < 3; ++variant) {
    const std::string file = path("v" + std::to_string(variant) + ".exr");
    write(file, variant == 1, variant == 2);
    Image im = read_image(file);
    ASSERT_EQ(im.width(), 2);
    ASSERT_EQ(im.height(), 2);
    for (int i = 0; i < 12; ++i) {
      // Every value above is exact in half precision, except 1e-3 (then within half's step).
      const float got = im.at((i / 3) % 2, i / 6, i % 3);
      if (px[i] == 1e-3f && !(variant == 1 && i % 3 == 2))
        EXPECT_NEAR(got, px[i], 1e-6f) << variant << " " << i;
      else
        EXPECT_EQ(got, px[i]) << variant << " " << i;
    }
  }
}

TEST_F(ImageIo, GreyAndAlphaPngsReadAsRgb) {
  auto write_raw = [](const std::string& file, int channels, const std::vector<unsigned char>& px) {
    auto out = OIIO::ImageOutput::create(file);
    ASSERT_TRUE(out);
    OIIO::ImageSpec spec(2, 1, channels, OIIO::TypeDesc::UINT8);
    spec.attribute("oiio:UnassociatedAlpha", 1);  // store the bytes as given
    ASSERT_TRUE(out->open(file, spec));
    ASSERT_TRUE(out->write_image(OIIO::TypeDesc::UINT8, px.data()));
    ASSERT_TRUE(out->close());
  };
  write_raw(path("grey.png"), 1, {0, 188});
  Image grey = read_image(path("grey.png"));
  ASSERT_EQ(grey.channels(), 3);
  for (int c = 0; c < 3; ++c) {
    EXPECT_EQ(grey.at(0, 0, c), 0.0f);
    EXPECT_NEAR(grey.at(1, 0, c), srgb_to_linear(188.0f / 255.0f), 1e-6);
  }
  // RGBA with a half-transparent pixel: the colour is kept as stored, alpha dropped.
  write_raw(path("rgba.png"), 4, {255, 188, 0, 128, 10, 20, 30, 0});
  Image rgba = read_image(path("rgba.png"));
  ASSERT_EQ(rgba.channels(), 3);
  EXPECT_NEAR(rgba.at(0, 0, 0), 1.0f, 1e-6);
  EXPECT_NEAR(rgba.at(0, 0, 1), srgb_to_linear(188.0f / 255.0f), 1e-6);
  EXPECT_NEAR(rgba.at(1, 0, 2), srgb_to_linear(30.0f / 255.0f), 1e-6);
}

TEST_F(ImageIo, MultipartRoundTrip) {
  std::vector<ExrPart> parts(4);
  parts[0] = {"color",
              {"R", "G", "B"},
              random_image(8, 6, 3, 6, 0.0f, 50.0f),
              {{"camera", "thin lens"}, {"focus_distance", "2.5"}}};
  parts[1] = {"depth", {"Z"}, random_image(8, 6, 1, 7, 0.1f, 100.0f), {}};
  Image ids(8, 6, 1);
  for (size_t i = 0; i < ids.data().size(); ++i)
    ids.data()[i] = static_cast<float>((i * 2654435761u) % 16777216u);  // up to 2^24 - 1
  ids.at(0, 0, 0) = 16777215.0f;
  parts[2] = {"ids", {"id"}, ids, {{"note", "object ids, exact below 2^24"}}};
  // A different size, and channel names not in sorted order (OpenEXR sorts them on disk).
  parts[3] = {"normals.half_res",
              {"N.Z", "N.X", "N.Y"},
              random_image(4, 3, 3, 8, -1.0f, 1.0f),
              {{"multi line", "a\nb"}, {"utf8", "f\xc3\xbc\x72 sch\xc3\xa4rfe"}}};

  const std::string file = path("inputs.exr");
  write_multipart_exr(file, parts);
  EXPECT_EQ(listing(), std::vector<std::string>{"inputs.exr"});

  std::vector<ExrPart> back = read_multipart_exr(file);
  ASSERT_EQ(back.size(), parts.size());
  for (size_t i = 0; i < parts.size(); ++i) {
    SCOPED_TRACE(parts[i].name);
    EXPECT_EQ(back[i].name, parts[i].name);
    EXPECT_EQ(back[i].channel_names, parts[i].channel_names);
    EXPECT_EQ(back[i].attributes, parts[i].attributes);
    expect_identical(back[i].image, parts[i].image);
  }
  EXPECT_EQ(back[2].image.at(0, 0, 0), 16777215.0f);

  // A single-part file reads as one part.
  write_image(path("single.exr"), parts[0].image, {{{"Z"}, parts[1].image}});
  std::vector<ExrPart> single = read_multipart_exr(path("single.exr"));
  ASSERT_EQ(single.size(), 1u);
  EXPECT_EQ(single[0].image.channels(), 4);
}

TEST_F(ImageIo, MultipartRejectsBadParts) {
  Image im(2, 2, 1);
  EXPECT_THROW(write_multipart_exr(path("dup.exr"), {{"a", {"Y"}, im, {}}, {"a", {"Y"}, im, {}}}),
               Error);
  EXPECT_THROW(write_multipart_exr(path("count.exr"), {{"a", {"Y", "Z"}, im, {}}}), Error);
  EXPECT_THROW(write_multipart_exr(path("none.exr"), {}), Error);
  EXPECT_THROW(write_multipart_exr(path("parts.png"), {{"a", {"Y"}, im, {}}}), Error);
  EXPECT_TRUE(listing().empty());
}

TEST_F(ImageIo, UnsupportedExtensionWritesNothing) {
  const std::string file = path("x.jpg2");
  std::string msg = error_of([&] { write_image(file, Image(2, 2, 3)); });
  EXPECT_EQ(msg, "cannot write '" + file + "': unsupported image format (use .exr or .png)");
  EXPECT_THROW(write_image(path("noext"), Image(2, 2, 3)), Error);
  EXPECT_TRUE(listing().empty());
}

TEST_F(ImageIo, MissingDirectoryWritesNothing) {
  const std::string file = path("missing/sub/out.exr");
  std::string msg = error_of([&] { write_image(file, Image(2, 2, 3)); });
  EXPECT_NE(msg.find("does not exist"), std::string::npos) << msg;
  EXPECT_THROW(write_image(path("missing/out.png"), Image(2, 2, 3)), Error);
  EXPECT_THROW(write_multipart_exr(path("missing/m.exr"), {{"a", {"Y"}, Image(2, 2, 1), {}}}),
               Error);
  EXPECT_TRUE(listing().empty());
}

TEST_F(ImageIo, UnwritableDirectoryWritesNothing) {
  if (::geteuid() == 0) GTEST_SKIP() << "root ignores directory permissions";
  fs::create_directories(dir_ / "ro");
  fs::permissions(dir_ / "ro", fs::perms::owner_read | fs::perms::owner_exec);
  std::string msg = error_of([&] { write_image(path("ro/out.exr"), Image(2, 2, 3)); });
  EXPECT_NE(msg.find("ro/out.exr"), std::string::npos) << msg;
  fs::permissions(dir_ / "ro", fs::perms::owner_all);
  EXPECT_TRUE(fs::is_empty(dir_ / "ro"));
}

TEST_F(ImageIo, FailedRenameLeavesNoTemporary) {
  // The target is a directory: the file is written, but renaming it over the target fails.
  fs::create_directories(dir_ / "taken.exr" / "inside");
  std::string msg = error_of([&] { write_image(path("taken.exr"), Image(2, 2, 3)); });
  EXPECT_NE(msg.find("taken.exr"), std::string::npos) << msg;
  EXPECT_EQ(listing(), std::vector<std::string>{"taken.exr"});
  // A parent that is a file, not a directory.
  std::ofstream(path("plain.txt")) << "x";
  EXPECT_THROW(write_image(path("plain.txt/out.png"), Image(2, 2, 3)), Error);
  EXPECT_EQ(listing(), (std::vector<std::string>{"plain.txt", "taken.exr"}));
}

TEST_F(ImageIo, FailedWriteLeavesExistingFileUntouched) {
  const std::string file = path("keep.exr");
  Image original = random_image(5, 4, 3, 9, 0.0f, 1.0f);
  write_image(file, original);
  // Extra channels of the wrong size: rejected before anything is written.
  EXPECT_THROW(write_image(file, Image(5, 4, 3), {{{"Z"}, Image(4, 4, 1)}}), Error);
  EXPECT_THROW(write_image(file, Image(5, 4, 3), {{{"R"}, Image(5, 4, 1)}}), Error);  // duplicate
  // A writer that fails half-way: the temporary is removed, the target kept.
  EXPECT_THROW(write_atomically(file,
                                [](const std::string& tmp) {
                                  std::ofstream(tmp) << "partial";
                                  throw Error("disk full");
                                }),
               Error);
  EXPECT_EQ(listing(), std::vector<std::string>{"keep.exr"});
  expect_identical(read_image(file), original);
}

TEST_F(ImageIo, ReadingMissingOrCorruptFilesIsAnError) {
  std::string msg = error_of([&] { read_image(path("nope.exr")); });
  EXPECT_NE(msg.find("nope.exr"), std::string::npos) << msg;
  EXPECT_THROW(read_channels(path("nope.exr"), {"Z"}), Error);
  EXPECT_THROW(read_multipart_exr(path("nope.exr")), Error);
  EXPECT_THROW(read_image(dir_.string()), Error);

  std::ofstream(path("garbage.exr"), std::ios::binary) << "this is not an image";
  std::ofstream(path("garbage.png"), std::ios::binary) << "\x89PNG but not really";
  error_of([&] { read_image(path("garbage.exr")); });
  error_of([&] { read_image(path("garbage.png")); });
  error_of([&] { read_multipart_exr(path("garbage.exr")); });

  // A valid file cut in half fails when its pixels are read.
  write_image(path("cut.exr"), random_image(64, 64, 3, 10, 0.0f, 1.0f));
  fs::resize_file(path("cut.exr"), fs::file_size(path("cut.exr")) / 2);
  error_of([&] { read_image(path("cut.exr")); });
}

// A small EXR whose header declares a 100000x100000 image (a 1x1 file with its data window
// widened and a line offset table long enough for OpenEXR to open it: about 50 KB).
std::string exr_declaring_100000_squared(const std::string& one_pixel_exr) {
  std::ifstream in(one_pixel_exr, std::ios::binary);
  std::string d((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto i32 = [](std::int32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); };
  const std::string window("dataWindow\0box2i\0", 17);
  std::size_t at = d.find(window);
  EXPECT_NE(at, std::string::npos);
  d.replace(at + window.size() + 4, 16, i32(0) + i32(0) + i32(99999) + i32(99999));
  std::size_t end = 8;  // magic and version, then attributes "name\0type\0<i32 size><value>"
  while (d.at(end) != 0) {
    std::size_t type_end = d.find('\0', d.find('\0', end) + 1);
    std::int32_t size;
    std::memcpy(&size, d.data() + type_end + 1, 4);
    end = type_end + 5 + static_cast<std::size_t>(size);
  }
  ++end;
  std::uint64_t chunk;
  std::memcpy(&chunk, d.data() + end, 8);
  const std::size_t chunks = (100000 + 15) / 16;  // ZIP: 16 lines per chunk
  const std::uint64_t moved = end + 8 * chunks;
  std::string table;
  for (std::size_t k = 0; k < chunks; ++k) table.append(reinterpret_cast<const char*>(&moved), 8);
  return d.substr(0, end) + table + d.substr(static_cast<std::size_t>(chunk));
}

// Found while writing the preview-inputs fuzz target (docs/reliability.md): such a file made every
// reader allocate 120 GB of floats from its header alone ("std::bad_alloc", or the machine's
// memory).
TEST_F(ImageIo, HugeDeclaredSizeIsRefusedBeforeReading) {
  write_image(path("one.exr"), Image(1, 1, 3, 0.5f));
  std::ofstream(path("huge.exr"), std::ios::binary)
      << exr_declaring_100000_squared(path("one.exr"));
  EXPECT_LT(fs::file_size(path("huge.exr")), 60000u);
  for (auto read : std::vector<std::function<void()>>{
           [&] { read_image(path("huge.exr")); },
           [&] { read_channels(path("huge.exr"), {"R"}); },
           [&] { read_multipart_exr(path("huge.exr")); }}) {
    std::string msg = error_of(read);
    EXPECT_NE(msg.find("huge.exr"), std::string::npos) << msg;
    EXPECT_NE(msg.find("100000x100000 pixels exceed the image size limit"), std::string::npos)
        << msg;
  }
  // The limit is exact and shared by the parts of a file.
  write_image(path("small.exr"), Image(4, 2, 3, 0.5f));
  EXPECT_EQ(read_image(path("small.exr"), 24).width(), 4);
  EXPECT_NE(error_of([&] { read_image(path("small.exr"), 23); }).find("(23 values in all)"),
            std::string::npos);
  write_multipart_exr(path("parts.exr"), {{"a", {"Y"}, Image(4, 2, 1), {}},
                                          {"b", {"Y"}, Image(4, 2, 1), {}}});
  EXPECT_EQ(read_multipart_exr(path("parts.exr"), 16).size(), 2u);
  error_of([&] { read_multipart_exr(path("parts.exr"), 15); });
}

// Found by fuzzing (the preview_inputs target, docs/reliability.md): a 2.7 KB file whose string
// attribute declared 1953366020 bytes made OpenEXR allocate and fill 1.9 GB before failing. The
// same damage, made from a valid file: refused from the header walk, before OpenEXR reads it.
TEST_F(ImageIo, ExrAttributeLongerThanTheFileIsRefused) {
  write_multipart_exr(path("ok.exr"),
                      {{"color", {"R", "G", "B"}, Image(2, 2, 3), {{"note", "x"}}}});
  std::ifstream in(path("ok.exr"), std::ios::binary);
  std::string d((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string attribute("dofcache:note\0string\0", 21);
  std::size_t at = d.find(attribute);
  ASSERT_NE(at, std::string::npos);
  const std::int32_t huge = 1953366020;
  d.replace(at + attribute.size(), 4, reinterpret_cast<const char*>(&huge), 4);
  std::ofstream(path("bad.exr"), std::ios::binary) << d;
  EXPECT_EQ(read_multipart_exr(path("ok.exr")).at(0).attributes.at("note"), "x");
  std::string msg = error_of([&] { read_multipart_exr(path("bad.exr")); });
  EXPECT_NE(msg.find("damaged EXR header (attribute 'dofcache:note' claims 1953366020 bytes"),
            std::string::npos) << msg;
}

// Found by fuzzing (preview_inputs): a channel of pixel type 3 made OpenImageIO abort on an
// assertion ("Unknown Imf::PixelType 3"), killing the process.
TEST_F(ImageIo, ExrChannelOfUnknownPixelTypeIsRefused) {
  write_image(path("ok.exr"), Image(2, 2, 3, 0.5f));
  std::ifstream in(path("ok.exr"), std::ios::binary);
  std::string d((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string list("channels\0chlist\0", 16);
  std::size_t at = d.find(list);
  ASSERT_NE(at, std::string::npos);
  at += list.size() + 4;  // the attribute's size, then the first channel: "B\0", pixel type
  ASSERT_EQ(d.substr(at, 2), std::string("B\0", 2));
  const std::int32_t type = 3;
  d.replace(at + 2, 4, reinterpret_cast<const char*>(&type), 4);
  std::ofstream(path("bad.exr"), std::ios::binary) << d;
  for (auto read : std::vector<std::function<void()>>{
           [&] { read_image(path("bad.exr")); }, [&] { read_multipart_exr(path("bad.exr")); }}) {
    std::string msg = error_of(read);
    EXPECT_NE(msg.find("channel 'B' has unknown pixel type 3"), std::string::npos) << msg;
  }
}

// Found by fuzzing (preview_inputs): OpenEXR reads a float attribute as 4 bytes whatever size it
// claims; one claiming 2 put OpenEXR 2 bytes past the header walk, where it read an attribute of
// 1.7 GB that the walk never saw. Attributes of fixed-size types must claim their size.
TEST_F(ImageIo, ExrFixedSizeAttributeOfAnotherSizeIsRefused) {
  write_multipart_exr(path("ok.exr"), {{"color", {"R", "G", "B"}, Image(2, 2, 3), {}}});
  std::ifstream in(path("ok.exr"), std::ios::binary);
  std::string d((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string attribute("pixelAspectRatio\0float\0", 23);
  std::size_t at = d.find(attribute);
  ASSERT_NE(at, std::string::npos);
  const std::int32_t two = 2;
  d.replace(at + attribute.size(), 4, reinterpret_cast<const char*>(&two), 4);
  d.erase(at + attribute.size() + 4, 2);  // the value now 2 bytes, as claimed
  std::ofstream(path("bad.exr"), std::ios::binary) << d;
  std::string msg = error_of([&] { read_multipart_exr(path("bad.exr")); });
  EXPECT_NE(msg.find("attribute 'pixelAspectRatio' of type float claims 2 bytes, not 4"),
            std::string::npos)
      << msg;
}

// Found by fuzzing (preview_inputs): OpenEXR reads a channel list up to its terminator, whatever
// size the attribute claims; a list claiming more bytes than that put OpenEXR past the header
// walk, where it read a 1.9 GB attribute. The list must end where its size says.
TEST_F(ImageIo, ExrChannelListNotEndingAtItsSizeIsRefused) {
  write_multipart_exr(path("ok.exr"), {{"color", {"R", "G", "B"}, Image(2, 2, 3), {}}});
  std::ifstream in(path("ok.exr"), std::ios::binary);
  std::string d((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string list("channels\0chlist\0", 16);
  std::size_t at = d.find(list);
  ASSERT_NE(at, std::string::npos);
  std::int32_t size;
  std::memcpy(&size, d.data() + at + list.size(), 4);
  const std::int32_t longer = size + 4;
  d.replace(at + list.size(), 4, reinterpret_cast<const char*>(&longer), 4);
  d.insert(at + list.size() + 4 + size, std::string(4, 'x'));  // after the terminator
  std::ofstream(path("bad.exr"), std::ios::binary) << d;
  std::string msg = error_of([&] { read_multipart_exr(path("bad.exr")); });
  EXPECT_NE(msg.find("channel list not ending where its size says"), std::string::npos) << msg;
}

// Found by fuzzing (preview_inputs): a 2.7 KB file of one scanline 2 million pixels wide, of 6
// channels, ZIP-compressed, made OpenEXR allocate 805 MB: its decompressor holds a block of 16
// scanlines of every channel, however few lines the image has. The header walk counts channels
// and compression blocks against the limit.
TEST_F(ImageIo, ExrCompressionBlockIsCountedAgainstTheLimit) {
  write_multipart_exr(path("ok.exr"), {{"color", {"R", "G", "B"}, Image(2, 1, 3), {}}});
  std::ifstream in(path("ok.exr"), std::ios::binary);
  std::string d((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string window("dataWindow\0box2i\0", 17), compression("compression\0compression\0", 24);
  std::size_t w = d.find(window), c = d.find(compression);
  ASSERT_NE(w, std::string::npos);
  ASSERT_NE(c, std::string::npos);
  const std::int32_t box[4] = {0, 0, 999999, 0};  // 1000000x1
  d.replace(w + window.size() + 4, 16, reinterpret_cast<const char*>(box), 16);
  d[c + compression.size() + 4] = 3;  // ZIP: 16 scanlines a block
  std::ofstream(path("wide.exr"), std::ios::binary) << d;
  // 3 million values fit a limit of 4 million; a block of 16 lines (48 million) does not.
  std::string msg = error_of([&] { read_multipart_exr(path("wide.exr"), 1 << 22); });
  EXPECT_NE(msg.find("1000000x1 pixels of 3 channels (decompressed 16000000 pixels at a time) "
                     "exceed the image size limit (4194304 values in all)"),
            std::string::npos)
      << msg;
  // Small images are never refused for their blocks: 2x1 of 3 channels fits a limit of 6.
  EXPECT_EQ(read_multipart_exr(path("ok.exr"), 6).size(), 1u);
  EXPECT_NE(error_of([&] { read_multipart_exr(path("ok.exr"), 5); }).find("(5 values in all)"),
            std::string::npos);
}

}  // namespace
}  // namespace dofcache::image
