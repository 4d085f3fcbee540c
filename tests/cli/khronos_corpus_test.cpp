// The Khronos glTF 2.0 sample models of tests/data/khronos/ (sources and licences in LICENSES.md
// there) rendered with `dofcache render` as a new user would: each loads, is lit by the default
// sky (none has a light) with its one-line notice and no other warning than the ones it asks
// for, and shows up in the image. Some are then checked against what their README says they are
// built to show, with expectations derived from the model's description and the documented
// camera conventions (docs/scenes.md), never from an earlier render.
#include <gtest/gtest.h>

#include "cli_harness.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <nlohmann/json.hpp>

#include "dofcache/image/image_io.h"

namespace {

namespace testing = dofcache::testing;
using dofcache::image::Image;

std::string model(const std::string& file) {
  return std::string(DOFCACHE_SOURCE_DIR) + "/tests/data/khronos/" + file;
}

const std::string kNotice = "dofcache: notice: the scene has no light; it is lit by a default sky";

// The background is black (the sky lights the model but is not seen), so any lit pixel is model.
const std::string kQuick =
    " --spp 2 --gather-rays 2 --light-samples 1 --env-visible off -q";

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

bool lit(const Image& img, int x, int y) {
  return std::max({img.at(x, y, 0), img.at(x, y, 1), img.at(x, y, 2)}) > 1e-4f;
}

double lit_fraction(const Image& img) {
  int n = 0;
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x) n += lit(img, x, y);
  return static_cast<double>(n) / static_cast<double>(img.pixel_count());
}

// Where a world point lands in the image of an unrotated camera at `eye` looking down -Z with
// vertical field of view `yfov` (the synthesised camera, and the Cameras model's): continuous
// pixel coordinates, x to the right, y down.
glm::vec2 project(const glm::vec3& p, const glm::vec3& eye, float yfov, int width, int height) {
  const float depth = eye.z - p.z;
  const float half_h = depth * std::tan(0.5f * yfov);
  const float half_w = half_h * static_cast<float>(width) / static_cast<float>(height);
  return {0.5f * width * (1.0f + (p.x - eye.x) / half_w),
          0.5f * height * (1.0f - (p.y - eye.y) / half_h)};
}

// The camera dofcache synthesises for a file without one (docs/scenes.md): looking down -Z at
// the centre of the bounds, from the distance at which the bounding sphere fills yfov = 0.8.
glm::vec3 synthesized_eye(const glm::vec3& lo, const glm::vec3& hi) {
  const glm::vec3 centre = 0.5f * (lo + hi);
  const float radius = 0.5f * glm::length(hi - lo);
  return centre + glm::vec3(0.0f, 0.0f, radius / std::sin(0.4f));
}

constexpr float kAutoFov = 0.8f;

struct CorpusModel {
  const char* file;
  const char* expected_warning;  // a warning the file deserves, or nullptr for none
};

class KhronosCorpus : public testing::CliTest,
                      public ::testing::WithParamInterface<CorpusModel> {};

TEST_P(KhronosCorpus, RendersUnderTheDefaultSkyWithOnlyTheWarningsItDeserves) {
  const CorpusModel& m = GetParam();
  const std::string out = (dir_ / "o.exr").string();
  testing::CliResult r = run("render " + model(m.file) + " --out " + out + " --width 32" + kQuick);
  ASSERT_EQ(r.exit_code, 0) << r.err;

  int notices = 0, expected = 0;
  for (const std::string& line : lines(r.err)) {
    if (line.rfind(kNotice, 0) == 0) {
      ++notices;
    } else if (m.expected_warning && line.rfind("dofcache: warning: ", 0) == 0 &&
               line.find(m.expected_warning) != std::string::npos) {
      ++expected;
    } else {
      ADD_FAILURE() << m.file << ": unexpected line on stderr: " << line;
    }
  }
  EXPECT_EQ(notices, 1) << r.err;
  EXPECT_EQ(expected, m.expected_warning ? 1 : 0) << r.err;

  const Image img = dofcache::image::read_image(out);
  ASSERT_GE(img.channels(), 3);
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x)
      for (int c = 0; c < 3; ++c) ASSERT_TRUE(std::isfinite(img.at(x, y, c))) << x << "," << y;
  // Every model is framed by its camera (its own, or the synthesised one): a good part of the
  // image shows it, lit.
  EXPECT_GT(lit_fraction(img), 0.05) << m.file;
}

INSTANTIATE_TEST_SUITE_P(
    Models, KhronosCorpus,
    ::testing::Values(CorpusModel{"AnimatedTriangle.gltf", nullptr},
                      CorpusModel{"Box.gltf", nullptr},
                      CorpusModel{"BoxVertexColors.gltf", nullptr},
                      // glTF allows orthographic cameras; dofcache renders through a lens.
                      CorpusModel{"Cameras.gltf", "'orthographic' camera skipped"},
                      CorpusModel{"MultipleScenes.gltf", nullptr},
                      CorpusModel{"SimpleMeshes.gltf", nullptr},
                      CorpusModel{"SimpleSparseAccessor.gltf", nullptr},
                      CorpusModel{"TextureCoordinateTest.gltf", nullptr},
                      CorpusModel{"Triangle.gltf", nullptr},
                      CorpusModel{"TriangleWithoutIndices.gltf", nullptr}),
    [](const auto& info) {
      std::string name = info.param.file;
      return name.substr(0, name.find('.'));
    });

// Models checked against what they show: sharp pinhole renders under a white environment that
// lights every direction alike (so that no pixel of a surface stays black by chance), not seen.
const std::string kSharp =
    " --mode pinhole --gather-rays 2 --light-samples 1 --env-color 1,1,1 --env-visible off -q";

class KhronosModels : public testing::CliTest {
 protected:
  Image render(const std::string& file, const std::string& extra = "") {
    const std::string out = (dir_ / "m.exr").string();
    testing::CliResult r =
        run("render " + model(file) + " --out " + out + " --width 64 --spp 8" + kSharp + extra);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return dofcache::image::read_image(out);
  }
};

// "The color of each vertex is given by the RGB colors that are defined by the vertex
// coordinates" (the model's README). The synthesised camera looks down -Z at the face z = 1,
// whose colour at (x, y) is (x, y, 1): cyan at the top left, white at the top right, blue at
// the bottom left, magenta at the bottom right. Shading scales all three channels of a point
// alike (white light, the default material's rough metal), so the test compares channel ratios
// between corners, from which it cancels.
TEST_F(KhronosModels, BoxVertexColorsShowTheirPositionsAsColours) {
  const Image img = render("BoxVertexColors.gltf");
  ASSERT_EQ(img.height(), 48);
  const glm::vec3 eye = synthesized_eye(glm::vec3(0.0f), glm::vec3(1.0f));
  auto colour_at = [&](float x, float y) {
    const glm::vec2 p = project(glm::vec3(x, y, 1.0f), eye, kAutoFov, 64, 48);
    const int px = static_cast<int>(p.x), py = static_cast<int>(p.y);
    glm::vec3 sum(0.0f);  // 2x2 pixels
    for (int dy = 0; dy < 2; ++dy)
      for (int dx = 0; dx < 2; ++dx)
        for (int c = 0; c < 3; ++c) sum[c] += img.at(px + dx, py + dy, c);
    return sum;
  };
  const glm::vec3 top_left = colour_at(0.2f, 0.8f), top_right = colour_at(0.8f, 0.8f);
  const glm::vec3 bottom_left = colour_at(0.2f, 0.2f), bottom_right = colour_at(0.8f, 0.2f);
  for (const glm::vec3& c : {top_left, top_right, bottom_left, bottom_right})
    ASSERT_GT(c.z, 1e-3f);  // every corner of the face is seen, and blue (z = 1) everywhere
  // Red follows x: (0.2 -> 0.8) is a factor 4 against blue, at either height.
  EXPECT_GT((top_right.x / top_right.z) / (top_left.x / top_left.z), 2.5f);
  EXPECT_GT((bottom_right.x / bottom_right.z) / (bottom_left.x / bottom_left.z), 2.5f);
  // Green follows y.
  EXPECT_GT((top_left.y / top_left.z) / (bottom_left.y / bottom_left.z), 2.5f);
  EXPECT_GT((top_right.y / top_right.z) / (bottom_right.y / bottom_right.z), 2.5f);
  // And neither follows the other axis.
  EXPECT_NEAR((top_right.x / top_right.z) / (bottom_right.x / bottom_right.z), 1.0f, 0.35f);
  EXPECT_NEAR((top_left.y / top_left.z) / (top_right.y / top_right.z), 1.0f, 0.35f);
}

// "The default scene is set to 1 by the scene property, so viewers should initially show the
// scene containing the square" (the model's README); scene 0 is the triangle (0,0) (1,0) (0,1).
TEST_F(KhronosModels, MultipleScenesShowsTheSquareByDefaultAndTheTriangleWhenAsked) {
  // Both scenes span (0,0)-(1,1), so the synthesised camera is the same for both.
  const glm::vec3 eye = synthesized_eye(glm::vec3(0.0f), glm::vec3(1.0f, 1.0f, 0.0f));
  const glm::vec2 upper_right = project(glm::vec3(0.8f, 0.8f, 0.0f), eye, kAutoFov, 64, 48);
  const glm::vec2 lower_left = project(glm::vec3(0.2f, 0.2f, 0.0f), eye, kAutoFov, 64, 48);
  const Image square = render("MultipleScenes.gltf");
  EXPECT_TRUE(lit(square, static_cast<int>(upper_right.x), static_cast<int>(upper_right.y)));
  EXPECT_TRUE(lit(square, static_cast<int>(lower_left.x), static_cast<int>(lower_left.y)));
  const Image triangle = render("MultipleScenes.gltf", " --scene-index 0");
  EXPECT_FALSE(lit(triangle, static_cast<int>(upper_right.x), static_cast<int>(upper_right.y)));
  EXPECT_TRUE(lit(triangle, static_cast<int>(lower_left.x), static_cast<int>(lower_left.y)));
  // The square covers twice the triangle's area.
  EXPECT_NEAR(lit_fraction(square) / lit_fraction(triangle), 2.0, 0.3);
}

// The sparse part of the POSITION accessor lifts vertices 8, 10 and 12 of the upper row (y = 1)
// to (1,2), (3,3) and (5,4) (the model's README, "Geometry"): three peaks of rising height over
// a band 0 <= y <= 1, with valleys at x = 0, 2, 4, 6. So the model's outline is the broken line
// through (0,1) (1,2) (2,1) (3,3) (4,1) (5,4) (6,1); without the sparse substitution it would
// be flat at y = 1. In every image column the topmost lit pixel must lie between the outline's
// lowest and highest points over the column's width.
TEST_F(KhronosModels, SimpleSparseAccessorShowsThreeRisingPeaks) {
  const Image img = render("SimpleSparseAccessor.gltf");
  ASSERT_EQ(img.height(), 48);
  const glm::vec3 eye = synthesized_eye(glm::vec3(0.0f), glm::vec3(6.0f, 4.0f, 0.0f));
  const float outline[7] = {1, 2, 1, 3, 1, 4, 1};  // at x = 0..6
  auto height_at = [&](float x) {
    const int i = std::clamp(static_cast<int>(x), 0, 5);
    return outline[i] + (x - static_cast<float>(i)) * (outline[i + 1] - outline[i]);
  };
  // World x at image column boundary `col` (the inverse of project() at depth eye.z).
  const float half_w = eye.z * std::tan(0.5f * kAutoFov) * 64.0f / 48.0f;
  auto world_x = [&](float col) { return eye.x + (col / 32.0f - 1.0f) * half_w; };
  auto row_of = [&](float y) { return project(glm::vec3(0.0f, y, 0.0f), eye, kAutoFov, 64, 48).y; };
  int columns = 0;
  for (int col = 0; col < img.width(); ++col) {
    const float x0 = world_x(static_cast<float>(col)), x1 = world_x(static_cast<float>(col + 1));
    if (x0 < 0.05f || x1 > 5.95f) continue;  // the model's ends
    float lo = 1e9f, hi = -1e9f;
    for (int k = 0; k <= 8; ++k) {
      const float h = height_at(x0 + (x1 - x0) * static_cast<float>(k) / 8.0f);
      lo = std::min(lo, h), hi = std::max(hi, h);
    }
    int top = 0;
    while (top < img.height() && !lit(img, col, top)) ++top;
    EXPECT_GE(static_cast<float>(top), std::floor(row_of(hi)) - 0.5f) << "column " << col;
    EXPECT_LE(static_cast<float>(top), row_of(lo) + 0.5f) << "column " << col;
    ++columns;
  }
  EXPECT_GT(columns, 30);
}

// The file's perspective camera (yfov 0.7, aspect 1, at (0.5, 0.5, 3)) sees the unit square
// tilted by the node's rotation quaternion (-0.383, 0, 0, 0.924): -45 degrees about X, so its
// top edge leans away from the camera and looks shorter than its bottom edge. The orthographic
// camera is skipped with a warning (checked above).
TEST_F(KhronosModels, CamerasModelIsSeenThroughItsPerspectiveCamera) {
  const Image img = render("Cameras.gltf");
  ASSERT_EQ(img.height(), 64);  // the camera's aspect ratio 1
  const glm::vec3 eye(0.5f, 0.5f, 3.0f);
  const float s = std::sqrt(0.5f);  // the square's corner (x, 1, 0) goes to (x, s, -s)
  const glm::vec2 bottom_left = project(glm::vec3(0.0f, 0.0f, 0.0f), eye, 0.7f, 64, 64);
  const glm::vec2 bottom_right = project(glm::vec3(1.0f, 0.0f, 0.0f), eye, 0.7f, 64, 64);
  const glm::vec2 top_left = project(glm::vec3(0.0f, s, -s), eye, 0.7f, 64, 64);
  const glm::vec2 top_right = project(glm::vec3(1.0f, s, -s), eye, 0.7f, 64, 64);
  auto width_of_row = [&](float y) {  // from the first lit pixel to the last
    int first = -1, last = -2;
    for (int x = 0; x < img.width(); ++x)
      if (lit(img, x, static_cast<int>(y))) {
        if (first < 0) first = x;
        last = x;
      }
    return static_cast<float>(last - first + 1);
  };
  // Rows just inside the bottom and top edges: the lit span is the edge's projected length.
  EXPECT_NEAR(width_of_row(bottom_left.y - 1.0f), bottom_right.x - bottom_left.x, 2.0f);
  EXPECT_NEAR(width_of_row(top_left.y + 1.0f), top_right.x - top_left.x, 2.0f);
  EXPECT_EQ(width_of_row(top_left.y - 2.0f), 0.0f);     // nothing above the top edge
  EXPECT_EQ(width_of_row(bottom_left.y + 2.0f), 0.0f);  // nor below the bottom edge
}

// TextureCoordinateTest is built to be seen from -Z (its squares face -Z; from +Z the grey back
// plane hides them), and has no camera: the test adds one to a copy, at (0, 0, -3.5) turned half
// a turn about Y (looking down +Z, so world +X is on the left of the image), yfov 0.8, aspect 1.
// What the model is built to show (its README and material names): the square named TopLeft
// (x, y in 0.2..1.2) is at the top left of the view, tinted yellow; TopRight red; BottomLeft
// blue; BottomRight green. And each shows the corner of the texture its name says, "the
// upper-left portion of the texture image is represented by texture coordinates ranging from
// roughly 0.0 to roughly 0.4": in the texture, each corner has checkers (half black) along its
// two outer edges, which meet at the image's corner and fade out towards the middle, so in each
// square the dark corner is its outer one, while the two corners beside it are white. A V
// coordinate read upside down, or U mirrored, moves the dark corner.
TEST_F(KhronosModels, TextureCoordinateTestShowsEachCornerOfItsTextureWhereItsNameSays) {
  nlohmann::json gltf = nlohmann::json::parse(testing::slurp(model("TextureCoordinateTest.gltf")));
  gltf["cameras"] = {{{"type", "perspective"},
                      {"perspective", {{"yfov", 0.8}, {"aspectRatio", 1.0}, {"znear", 0.01}}}}};
  gltf["nodes"].push_back(
      {{"name", "view"}, {"camera", 0}, {"translation", {0, 0, -3.5}}, {"rotation", {0, 1, 0, 0}}});
  gltf["scenes"][0]["nodes"].push_back(gltf["nodes"].size() - 1);
  const std::string file = (dir_ / "tct.gltf").string();
  std::ofstream(file) << gltf.dump();

  const int size = 160;
  const std::string out = (dir_ / "t.exr").string();
  testing::CliResult r =
      run("render " + file + " --out " + out + " --width " + std::to_string(size) + " --spp 16" + kSharp);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Image img = dofcache::image::read_image(out);
  ASSERT_EQ(img.height(), size);

  // Pixel of a world point on the squares (z = 0) for this camera: +X to the left.
  const float half = 3.5f * std::tan(0.4f);
  auto pixel = [&](float x, float y) {
    return glm::vec2(0.5f * size * (1.0f - x / half), 0.5f * size * (1.0f - y / half));
  };
  // Mean colour over the pixels whose centres lie in the world rectangle spanned by a and b.
  auto mean = [&](glm::vec2 a, glm::vec2 b) {
    const glm::vec2 pa = pixel(a.x, a.y), pb = pixel(b.x, b.y);
    const glm::vec2 lo = glm::min(pa, pb), hi = glm::max(pa, pb);
    glm::vec3 sum(0.0f);
    int n = 0;
    for (int y = 0; y < size; ++y)
      for (int x = 0; x < size; ++x)
        if (x + 0.5f > lo.x && x + 0.5f < hi.x && y + 0.5f > lo.y && y + 0.5f < hi.y) {
          for (int c = 0; c < 3; ++c) sum[c] += img.at(x, y, c);
          ++n;
        }
    EXPECT_GT(n, 8) << "region too small";
    return n ? sum / static_cast<float>(n) : sum;
  };

  struct Square {
    const char* name;
    glm::vec2 outer;  // its outer corner (the texture's corner), world x, y
  };
  // Corner regions of 0.08 m of the 1 m square, 0.04 m in from its edges (so that no pixel
  // straddles an edge): 0.08 x 0.08 of the 0.4 of the texture each square shows. In the texture,
  // the outer corner's region (checkers) averages 0.55 of the white of the two corners beside it
  // (linear, computed from the PNG's texels); filtering blurs that a little.
  const float k = 0.08f, margin = 0.04f;
  for (const Square& q : {Square{"TopLeft", {1.2f, 1.2f}}, Square{"TopRight", {-1.2f, 1.2f}},
                          Square{"BottomLeft", {1.2f, -1.2f}},
                          Square{"BottomRight", {-1.2f, -1.2f}}}) {
    SCOPED_TRACE(q.name);
    const glm::vec2 in(q.outer.x > 0 ? -1.0f : 1.0f, q.outer.y > 0 ? -1.0f : 1.0f);  // inwards
    const glm::vec2 centre = q.outer + 0.5f * in;
    // The square's place in the view: its tint, from its material.
    const glm::vec3 c = mean(centre - glm::vec2(0.15f), centre + glm::vec2(0.15f));
    const std::string name = q.name;
    if (name == "TopLeft") {  // yellow (1, 1, 0)
      EXPECT_GT(c.r, 3.0f * c.b);
      EXPECT_GT(c.g, 3.0f * c.b);
    } else if (name == "TopRight") {  // red (1, 0.1, 0)
      EXPECT_GT(c.r, 3.0f * c.g);
      EXPECT_GT(c.r, 3.0f * c.b);
    } else if (name == "BottomLeft") {  // blue (0, 0.2, 1)
      EXPECT_GT(c.b, 3.0f * c.r);
      EXPECT_GT(c.b, 2.0f * c.g);
    } else {  // green (0, 1, 0)
      EXPECT_GT(c.g, 3.0f * c.r);
      EXPECT_GT(c.g, 3.0f * c.b);
    }
    // The texture's orientation: the outer corner is dark, the corners beside it are white.
    auto brightness = [&](glm::vec2 a, glm::vec2 b) {
      const glm::vec3 m = mean(a, b);
      return m.r + m.g + m.b;
    };
    const float near = margin, far = margin + k;  // from the outer edge
    const float inner_near = 1.0f - margin - k, inner_far = 1.0f - margin;  // by the inner edge
    const glm::vec2 o = q.outer;
    const float outer = brightness(o + near * in, o + far * in);
    const float along_x = brightness({o.x + inner_near * in.x, o.y + near * in.y},
                                     {o.x + inner_far * in.x, o.y + far * in.y});
    const float along_y = brightness({o.x + near * in.x, o.y + inner_near * in.y},
                                     {o.x + far * in.x, o.y + inner_far * in.y});
    EXPECT_LT(outer, 0.8f * along_x) << outer << " vs " << along_x;
    EXPECT_LT(outer, 0.8f * along_y) << outer << " vs " << along_y;
  }
}

}  // namespace
