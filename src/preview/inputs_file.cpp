#include "dofcache/preview/inputs_file.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "dofcache/core/error.h"
#include "dofcache/image/image_io.h"

namespace dofcache::preview {
namespace {

constexpr const char* kFormat = "dofcache-preview-inputs";
constexpr int kVersion = 1;

std::string number(double v) {
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

// A revealed layer as the list of its mask's pixels (x, y) with their colour and depth, row-major,
// packed into rows of `width` entries; unused entries at the end have x = -1. The masks are thin
// rings around occluders, so this is a fraction of the dense size (and of the load time).
image::ExrPart revealed_part(const RevealedLayer& r, int index) {
  const int w = r.mask.width(), h = r.mask.height();
  std::vector<std::array<float, 6>> entries;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (r.mask.at(x, y, 0) > 0.5f) {
        const float* c = r.color.pixel(x, y);
        entries.push_back(
            {static_cast<float>(x), static_cast<float>(y), c[0], c[1], c[2], r.depth.at(x, y, 0)});
      }
  const int rows = std::max<int>(1, static_cast<int>((entries.size() + w - 1) / w));
  image::Image packed(w, rows, 6, 0.0f);
  for (size_t i = 0; i < static_cast<size_t>(w) * rows; ++i) {
    float* p = packed.data().data() + 6 * i;
    if (i < entries.size())
      std::copy(entries[i].begin(), entries[i].end(), p);
    else
      p[0] = p[1] = -1.0f;
  }
  return {"revealed." + std::to_string(index),
          {"x", "y", "R", "G", "B", "Z"},
          std::move(packed),
          {{"near_depth", number(r.near_depth)}, {"pixels", std::to_string(entries.size())}}};
}

// Reading: every problem becomes one line naming the file.
class Reader {
 public:
  explicit Reader(std::string path) : path_(std::move(path)) {}

  // `what` may quote the file's own text, line breaks and all: the message is made one line.
  [[noreturn]] void fail(const std::string& what) const {
    throw Error("'" + path_ + "' is not a usable preview-inputs file: " + one_line(what));
  }

  image::ExrPart& part(std::vector<image::ExrPart>& parts, const std::string& name,
                       const std::vector<std::string>& channels) const {
    auto it = std::find_if(parts.begin(), parts.end(),
                           [&](const image::ExrPart& p) { return p.name == name; });
    if (it == parts.end()) fail("no '" + name + "' part");
    if (it->channel_names != channels) fail("part '" + name + "' has unexpected channels");
    return *it;
  }

  std::string text(const image::ExrPart& part, const std::string& key) const {
    auto it = part.attributes.find(key);
    if (it == part.attributes.end()) fail("part '" + part.name + "' lacks the '" + key + "' value");
    return it->second;
  }

  double real(const image::ExrPart& part, const std::string& key) const {
    std::string s = text(part, key);
    errno = 0;
    char* end = nullptr;
    double v = std::strtod(s.c_str(), &end);
    if (s.empty() || *end != '\0' || std::isnan(v) || errno == ERANGE)
      fail("'" + key + "' is not a number ('" + s + "')");
    return v;
  }

  int integer(const image::ExrPart& part, const std::string& key, int lo, int hi) const {
    double v = real(part, key);
    if (!(v >= lo && v <= hi) || v != std::floor(v))
      fail("'" + key + "' must be an integer in [" + std::to_string(lo) + ", " +
           std::to_string(hi) + "]");
    return static_cast<int>(v);
  }

 private:
  std::string path_;
};

}  // namespace

namespace {

// The aperture's numbers as the file's attributes, one table for the writer and the reader.
struct ApertureReal {
  const char* key;
  double& (*field)(lens::ApertureShape&);
};
constexpr ApertureReal kApertureReals[] = {
    {"aperture_rotation", [](lens::ApertureShape& a) -> double& { return a.rotation_deg; }},
    {"aperture_roundness", [](lens::ApertureShape& a) -> double& { return a.roundness; }},
    {"anamorphic_ratio", [](lens::ApertureShape& a) -> double& { return a.anamorphic_ratio; }},
    {"vignetting_stop_radius", [](lens::ApertureShape& a) -> double& { return a.stop.radius; }},
    {"vignetting_stop_distance",
     [](lens::ApertureShape& a) -> double& { return a.stop.distance; }},
    {"axial_ca", [](lens::ApertureShape& a) -> double& { return a.axial_ca; }},
    {"lateral_ca", [](lens::ApertureShape& a) -> double& { return a.lateral_ca; }},
    {"aperture_profile_strength",
     [](lens::ApertureShape& a) -> double& { return a.profile_strength; }},
    {"lens_tilt_x", [](lens::ApertureShape& a) -> double& { return a.tilt_x_deg; }},
    {"lens_tilt_y", [](lens::ApertureShape& a) -> double& { return a.tilt_y_deg; }},
    {"lens_shift_x", [](lens::ApertureShape& a) -> double& { return a.shift_x; }},
    {"lens_shift_y", [](lens::ApertureShape& a) -> double& { return a.shift_y; }},
};
// A real lens's rims (lens/lens_rims.h): written where the lens has them, read where present.
constexpr ApertureReal kRimReals[] = {
    {"lens_rims_front_radius", [](lens::ApertureShape& a) -> double& { return a.rims.front.radius; }},
    {"lens_rims_front_distance",
     [](lens::ApertureShape& a) -> double& { return a.rims.front.distance; }},
    {"lens_rims_rear_radius", [](lens::ApertureShape& a) -> double& { return a.rims.rear.radius; }},
    {"lens_rims_rear_distance",
     [](lens::ApertureShape& a) -> double& { return a.rims.rear.distance; }},
};

}  // namespace

void save_preview_inputs(const std::string& path, const PreviewInputs& in,
                         const RevealedCoverage& coverage, const PreviewOptions& options) {
  const int w = in.color.width(), h = in.color.height();
  if (in.color.empty() || in.color.channels() != 3 || !in.depth.same_shape(image::Image(w, h, 1)) ||
      !in.ids.same_shape(image::Image(w, h, 1)))
    throw Error("cannot save preview inputs to '" + path +
                "': colour, depth and ids must be RGB, 1 and 1 channels of one size");
  const lens::LensImaging& im = in.imaging;
  std::map<std::string, std::string> a = {
      {"format", kFormat},
      {"version", std::to_string(kVersion)},
      {"focal_length", number(im.lens.focal_length)},
      {"fstop", number(im.lens.fstop)},
      {"focus_distance", number(im.lens.focus_distance)},
      {"yfov", number(im.yfov)},
      {"width", std::to_string(w)},
      {"height", std::to_string(h)},
      {"max_coc_radius", number(options.max_coc_radius)},
      {"max_layers", std::to_string(options.max_layers)},
      {"min_layer_step", number(options.min_layer_step)},
      {"layer_count", std::to_string(options.layer_count)},
      {"mask_lens_reach", options.mask_lens_reach ? "1" : "0"},
      {"revealed_present", coverage.present ? "1" : "0"},
      {"revealed_near_depth", number(coverage.near_depth)},
      {"revealed_far_depth", number(coverage.far_depth)},
      {"revealed_aperture", number(coverage.aperture_diameter)}};
  // The lens's character (lens/aperture.h), for the shaped scatter; absent: the plain lens.
  lens::ApertureShape ap = im.lens.aperture;
  if (!ap.plain()) {
    a["aperture_blades"] = std::to_string(ap.blades);
    for (const ApertureReal& r : kApertureReals) a[r.key] = number(r.field(ap));
    a["aperture_profile"] = lens::aperture_profile_name(ap.profile);
    if (!ap.image.empty()) a["aperture_image"] = ap.image;
    if (ap.rims.any()) {
      for (const ApertureReal& r : kRimReals) a[r.key] = number(r.field(ap));
      a["lens_rims_normalised"] = ap.rims.normalised ? "1" : "0";
    }
  }
  std::vector<image::ExrPart> parts = {{"color", {"R", "G", "B"}, in.color, a},
                                       {"depth", {"Z"}, in.depth, {}},
                                       {"ids", {"id"}, in.ids, {}}};
  for (size_t k = 0; k < in.revealed.size(); ++k) {
    const RevealedLayer& r = in.revealed[k];
    if (!r.color.same_shape(in.color) || !r.depth.same_shape(in.depth) ||
        !r.mask.same_shape(in.depth))
      throw Error("cannot save preview inputs to '" + path +
                  "': a revealed layer does not match the pinhole image's size");
    parts.push_back(revealed_part(r, static_cast<int>(k)));
  }
  image::write_multipart_exr(path, parts);
}

SavedPreviewInputs load_preview_inputs(const std::string& path, std::uint64_t max_values) {
  std::vector<image::ExrPart> parts = image::read_multipart_exr(path, max_values);
  Reader rd(path);
  image::ExrPart& color = rd.part(parts, "color", {"R", "G", "B"});
  if (color.attributes.count("format") == 0 || color.attributes.at("format") != kFormat)
    rd.fail("it was not written by 'dofcache render --save-preview-inputs'");
  if (rd.integer(color, "version", 0, 1 << 20) != kVersion)
    rd.fail("unsupported version " + rd.text(color, "version"));
  const int w = rd.integer(color, "width", 1, 16384), h = rd.integer(color, "height", 1, 16384);
  if (color.image.width() != w || color.image.height() != h) rd.fail("the colour part's size");

  SavedPreviewInputs s;
  PreviewInputs& in = s.inputs;
  in.color = std::move(color.image);
  in.depth = std::move(rd.part(parts, "depth", {"Z"}).image);
  in.ids = std::move(rd.part(parts, "ids", {"id"}).image);
  if (in.depth.width() != w || in.depth.height() != h || in.ids.width() != w ||
      in.ids.height() != h)
    rd.fail("depth and ids must have the colour's size");
  in.imaging.lens = {rd.real(color, "focal_length"), rd.real(color, "fstop"),
                     rd.real(color, "focus_distance")};
  if (color.attributes.count("aperture_blades")) {
    lens::ApertureShape& ap = in.imaging.lens.aperture;
    ap.blades = rd.integer(color, "aperture_blades", 0, lens::kMaxBlades);
    for (const ApertureReal& r : kApertureReals) r.field(ap) = rd.real(color, r.key);
    try {
      ap.profile = lens::parse_aperture_profile(rd.text(color, "aperture_profile"));
    } catch (const Error& e) {
      rd.fail(e.what());
    }
    if (color.attributes.count("aperture_image")) ap.image = rd.text(color, "aperture_image");
    if (color.attributes.count("lens_rims_normalised")) {
      for (const ApertureReal& r : kRimReals) r.field(ap) = rd.real(color, r.key);
      ap.rims.normalised = rd.integer(color, "lens_rims_normalised", 0, 1) == 1;
    }
  }
  try {
    in.imaging.lens.validate();
  } catch (const Error& e) {
    rd.fail(e.what());
  }
  in.imaging.yfov = rd.real(color, "yfov");
  if (!(in.imaging.yfov > 0.0 && in.imaging.yfov < 3.1)) rd.fail("field of view out of range");
  in.imaging.y_resolution = h;

  PreviewOptions& o = s.options;
  o.max_coc_radius = rd.real(color, "max_coc_radius");
  o.max_layers = rd.integer(color, "max_layers", 1, 64);
  o.min_layer_step = rd.real(color, "min_layer_step");
  o.layer_count = rd.integer(color, "layer_count", 0, 64);
  o.mask_lens_reach = rd.integer(color, "mask_lens_reach", 0, 1) == 1;
  if (!(o.max_coc_radius > 0.0 && o.max_coc_radius <= 1e4) ||
      !(o.min_layer_step > 0.0 && o.min_layer_step <= 1e4))
    rd.fail("layer options out of range");

  RevealedCoverage& c = s.coverage;
  c.present = rd.integer(color, "revealed_present", 0, 1) == 1;
  c.near_depth = rd.real(color, "revealed_near_depth");
  c.far_depth = rd.real(color, "revealed_far_depth");
  c.aperture_diameter = rd.real(color, "revealed_aperture");
  if (c.present && !(c.near_depth > 0.0 && c.far_depth >= c.near_depth &&
                     c.aperture_diameter > 0.0 && std::isfinite(c.aperture_diameter)))
    rd.fail("the revealed layers' depth range is invalid");

  std::vector<const image::ExrPart*> revealed;
  for (const image::ExrPart& part : parts) {
    if (part.name.rfind("revealed.", 0) != 0) continue;
    if (part.channel_names != std::vector<std::string>{"x", "y", "R", "G", "B", "Z"})
      rd.fail("part '" + part.name + "' has unexpected channels");
    if (part.image.width() != w) rd.fail("part '" + part.name + "' has the wrong width");
    revealed.push_back(&part);
  }
  // Each list expands to a dense layer (RGB, depth, mask) of the image's size: bound what the
  // file makes us allocate, not only what it holds.
  if (revealed.size() > 64) rd.fail("more than 64 revealed layers");
  const std::uint64_t dense = (5 + 5 * std::uint64_t(revealed.size())) * std::uint64_t(w) * h;
  if (dense > max_values)
    rd.fail(std::to_string(revealed.size()) + " revealed layers of " + std::to_string(w) + "x" +
            std::to_string(h) + " exceed the image size limit (" + std::to_string(max_values) +
            " values; raise it with --max-image-values)");
  // Expanding the lists into dense layers is most of the time after reading: one task per layer.
  in.revealed.resize(revealed.size());
  tbb::parallel_for(size_t{0}, revealed.size(), [&](size_t k) {
    const image::ExrPart& part = *revealed[k];
    RevealedLayer& r = in.revealed[k];
    r.near_depth = rd.real(part, "near_depth");
    if (!(r.near_depth > 0.0)) rd.fail("part '" + part.name + "' has an invalid near depth");
    r.color = image::Image(w, h, 3, 0.0f);
    r.depth = image::Image(w, h, 1, std::numeric_limits<float>::infinity());
    r.mask = image::Image(w, h, 1, 0.0f);
    for (size_t i = 0; i < part.image.pixel_count(); ++i) {
      const float* v = part.image.data().data() + 6 * i;
      if (v[0] < 0.0f) continue;  // padding
      // Range first (NaN fails it): converting an out-of-range float to int is undefined.
      if (!(v[0] < w && v[1] >= 0.0f && v[1] < h) || v[0] != std::floor(v[0]) ||
          v[1] != std::floor(v[1]))
        rd.fail("part '" + part.name + "' lists a pixel outside the image");
      const int x = static_cast<int>(v[0]), y = static_cast<int>(v[1]);
      std::copy_n(v + 2, 3, r.color.pixel(x, y));
      r.depth.at(x, y, 0) = v[5];
      r.mask.at(x, y, 0) = 1.0f;
    }
  });
  if (!c.present && !in.revealed.empty()) rd.fail("revealed layers without their depth range");
  return s;
}

}  // namespace dofcache::preview
