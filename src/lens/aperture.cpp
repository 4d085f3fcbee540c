#include "dofcache/lens/aperture.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "dofcache/core/error.h"
#include "dofcache/core/shared_cache.h"
#include "dofcache/image/image_io.h"
#include "dofcache/lens/thin_lens.h"

namespace dofcache::lens {
namespace {

constexpr double kPi = 3.14159265358979323846;

double radians(double degrees) { return degrees * kPi / 180.0; }

}  // namespace

void ApertureShape::validate() const {
  if (blades != 0 && (blades < kMinBlades || blades > kMaxBlades))
    throw Error("lens: aperture blades must be 0 (round) or " + std::to_string(kMinBlades) + " to " +
                std::to_string(kMaxBlades) + ", got " + std::to_string(blades));
  if (!std::isfinite(rotation_deg))
    throw Error("lens: aperture rotation must be a finite angle in degrees");
  if (!(roundness >= 0.0 && roundness <= 1.0))
    throw Error("lens: aperture roundness must be in [0, 1] (0: straight blades, 1: round), got " +
                std::to_string(roundness));
  if (!(anamorphic_ratio > 0.0) || !std::isfinite(anamorphic_ratio) || anamorphic_ratio > 100.0)
    throw Error("lens: anamorphic ratio must be > 0 and at most 100 (the bokeh's height over its "
                "width), got " + std::to_string(anamorphic_ratio));
  if (!(stop == VignettingStop{}) &&
      !(stop.radius > 0.0 && stop.radius < 1e3 && stop.distance > 0.0 && stop.distance < 1e3))
    throw Error("lens: the vignetting stop needs a radius and a distance in front of the "
                "aperture, both > 0 and finite (metres), got " + std::to_string(stop.radius) +
                ", " + std::to_string(stop.distance));
  for (const VignettingStop* rim : {&rims.front, &rims.rear})
    if (!(*rim == VignettingStop{}) &&
        !(rim->radius > 0.0 && rim->radius < 1e3 && rim->distance > 0.0 && rim->distance < 1e3))
      throw Error("lens: a lens rim needs a radius and a distance, both > 0 and finite (metres), "
                  "got " + std::to_string(rim->radius) + ", " + std::to_string(rim->distance));
  if (rims.any() && vignetting())
    throw Error("lens: a vignetting stop and a real lens's rims exclude each other");
  if (!std::isfinite(axial_ca) || !(std::abs(axial_ca) < 1e3))
    throw Error("lens: axial chromatic aberration must be a finite distance in metres, got " +
                std::to_string(axial_ca));
  if (!(std::abs(lateral_ca) <= 0.2))
    throw Error("lens: lateral chromatic aberration must be within [-0.2, 0.2] (red's "
                "magnification over blue's, minus 1), got " + std::to_string(lateral_ca));
  if (!(profile_strength >= 0.0 && profile_strength <= 1.0))
    throw Error("lens: aperture profile strength must be in [0, 1], got " +
                std::to_string(profile_strength));
  if (!(std::abs(tilt_x_deg) < 90.0 && std::abs(tilt_y_deg) < 90.0))
    throw Error("lens: tilt must be under 90 degrees each way, got " + std::to_string(tilt_x_deg) +
                ", " + std::to_string(tilt_y_deg));
  if (!(std::abs(shift_x) <= 1.0 && std::abs(shift_y) <= 1.0))
    throw Error("lens: shift must be within one image height each way, got " +
                std::to_string(shift_x) + ", " + std::to_string(shift_y));
}

double ApertureShape::transmission(double rho) const {
  if (!weighted()) return 1.0;
  const double s = profile_strength, r2 = rho * rho;
  const double t = profile == ApertureProfile::Centre ? 1.0 - s * r2 : 1.0 - s + s * r2;
  return t / (1.0 - 0.5 * s);
}

ApertureProfile parse_aperture_profile(const std::string& name) {
  if (name == "uniform") return ApertureProfile::Uniform;
  if (name == "centre" || name == "center") return ApertureProfile::Centre;
  if (name == "rim") return ApertureProfile::Rim;
  throw Error("lens: unknown aperture profile '" + name + "' (uniform, centre or rim)");
}

const char* aperture_profile_name(ApertureProfile profile) {
  switch (profile) {
    case ApertureProfile::Centre: return "centre";
    case ApertureProfile::Rim: return "rim";
    default: return "uniform";
  }
}

double ApertureShape::footprint_scale() const {
  // An aperture image's inradius is not known without reading it: half the round aperture's, a
  // footprint within most bokeh images (docs/lens.md).
  if (!image.empty()) return 0.5;
  return blades == 0 ? 1.0 : (1.0 - roundness) * std::cos(kPi / blades) + roundness;
}

double ApertureShape::inner_scale() const {
  const glm::dvec2 squeeze = footprint_squeeze();
  return footprint_scale() * std::min(squeeze.x, squeeze.y);
}

std::optional<int> blade_count(double value) {
  if (value != std::floor(value) || !(std::abs(value) <= 1e6)) return std::nullopt;
  return static_cast<int>(value);
}

ApertureChoices ApertureChoices::over(const ApertureChoices& fallback) const {
  return {blades ? blades : fallback.blades,
          rotation_deg ? rotation_deg : fallback.rotation_deg,
          roundness ? roundness : fallback.roundness,
          anamorphic_ratio ? anamorphic_ratio : fallback.anamorphic_ratio,
          vignetting_stop ? vignetting_stop : fallback.vignetting_stop,
          axial_ca ? axial_ca : fallback.axial_ca,
          lateral_ca ? lateral_ca : fallback.lateral_ca,
          profile ? profile : fallback.profile,
          profile_strength ? profile_strength : fallback.profile_strength,
          lens_tilt ? lens_tilt : fallback.lens_tilt,
          lens_shift ? lens_shift : fallback.lens_shift,
          image ? image : fallback.image};
}

ApertureShape ApertureChoices::shape() const {
  const ApertureShape round;
  return {blades.value_or(round.blades), rotation_deg.value_or(round.rotation_deg),
          roundness.value_or(round.roundness), anamorphic_ratio.value_or(round.anamorphic_ratio),
          vignetting_stop.value_or(round.stop), axial_ca.value_or(0.0),
          lateral_ca.value_or(0.0), profile.value_or(round.profile),
          profile_strength.value_or(round.profile_strength),
          lens_tilt ? lens_tilt->first : 0.0, lens_tilt ? lens_tilt->second : 0.0,
          lens_shift ? lens_shift->first : 0.0, lens_shift ? lens_shift->second : 0.0,
          image.value_or("")};
}

ApertureChoices ApertureChoices::of(const ApertureShape& s) {
  ApertureChoices c;
  c.blades = s.blades, c.rotation_deg = s.rotation_deg, c.roundness = s.roundness;
  c.anamorphic_ratio = s.anamorphic_ratio, c.axial_ca = s.axial_ca, c.lateral_ca = s.lateral_ca;
  c.profile = s.profile, c.profile_strength = s.profile_strength;
  if (s.vignetting()) c.vignetting_stop = s.stop;
  if (s.tilted()) c.lens_tilt = std::pair{s.tilt_x_deg, s.tilt_y_deg};
  if (s.shifted()) c.lens_shift = std::pair{s.shift_x, s.shift_y};
  if (!s.image.empty()) c.image = s.image;
  return c;
}

namespace {

// One way of drawing a bin in proportion to its weight: the bins that have any, each with its
// cumulative share below and above (0 first, 1 last) and its index among all bins, and a guide
// table of `cells` cells: the bin holding the least u of each cell, from which the bin of any u in
// the cell is a scan of at most `steps` forward. Empty bins are left out, so no scan crosses the
// dark gap between two of an image's shapes; the guide is made finer until one step suffices,
// and the scan's length is known, so it runs as fixed steps, without a branch to mispredict (a
// mispredicted branch costs a tenth of a thin-lens ray).
struct BinSampler {
  struct Bin {
    float lo, hi;         // the cumulative share below and above it
    float inverse_share;  // 1 / (hi - lo): a product where a division would be slower
    int index;            // among all bins
  };
  std::vector<Bin> bins;
  std::vector<int> guide;
  float cells = 0;  // guide.size()
  int steps = 0;

  // From the cumulative shares of all bins (first 0, last 1).
  void build(const float* all, int count) {
    bins.clear();
    for (int i = 0; i < count; ++i)
      if (all[i + 1] > all[i]) bins.push_back({all[i], all[i + 1], 1.0f / (all[i + 1] - all[i]), i});
    bins.back().hi = 1.0f;
    const int n = static_cast<int>(bins.size());
    for (int fine = 1;; fine *= 2) {
      build_guide(n * fine);
      if (steps <= 1 || fine >= kMaxFineness || n * fine * 2 > kMaxCells) break;
    }
  }

  void build_guide(int g) {
    guide.resize(g);
    cells = static_cast<float>(g);
    const int n = static_cast<int>(bins.size());
    int i = 0;
    for (int k = 0; k < g; ++k) {
      // The least u that invert() looks up in cell k (u * cells rounds in float).
      float u = static_cast<float>(k) / cells;
      while (static_cast<int>(u * cells) < k) u = std::nextafter(u, 1.0f);
      while (u > 0.0f && static_cast<int>(std::nextafter(u, 0.0f) * cells) >= k)
        u = std::nextafter(u, 0.0f);
      while (i < n - 1 && bins[i].hi <= u) ++i;
      guide[k] = i;
    }
    steps = 0;
    for (int k = 0; k < g; ++k) steps = std::max(steps, (k + 1 < g ? guide[k + 1] : n - 1) - guide[k]);
  }

  // The bin (among all) holding u in [0, 1), and u's place within it, scanning `fixed` steps
  // (at least `steps`; more are harmless) or, past kMaxFixedSteps, as far as it takes. One
  // image's samplers all take the same, so the switch is always predicted.
  std::pair<int, float> invert(float u, int fixed) const {
    u = std::min(u, 0x1.fffffep-1f);  // below 1, so no scan passes the last bin (hi = 1)
    int i = guide[std::min(static_cast<int>(guide.size()) - 1, static_cast<int>(u * cells))];
    switch (fixed) {
      case 0: break;
      case 1: i += bins[i].hi <= u; break;
      default: while (bins[i].hi <= u) ++i;
    }
    const Bin& b = bins[i];
    return {b.index, std::min(1.0f, std::max(0.0f, (u - b.lo) * b.inverse_share))};
  }

  static constexpr int kMaxFixedSteps = 1, kMaxFineness = 8, kMaxCells = 1 << 14;
};

}  // namespace

// The cumulative transmission of an aperture image down its rows (h + 1 values, 0 first, 1
// last) and along each row (w + 1 values per row, likewise), which give a pixel's transmission,
// and the samplers of rows and, per row, of columns that draw a pixel.
struct Aperture::ImageTables {
  int w = 0, h = 0;
  float pixel_x = 0, pixel_y = 0;  // a pixel's size in the square [-1, 1]^2: 2 / w, 2 / h
  float peak = 0;  // the largest pixel's share of the total (row share x column share)
  std::vector<float> row_cdf, column_cdf;
  BinSampler rows;
  std::vector<BinSampler> columns;  // per row (empty for a dark row)
  int steps = 0;  // the scan every sampler's invert() takes: the longest, or any beyond 1
};

namespace {

std::shared_ptr<const Aperture::ImageTables> build_image_tables(const std::string& path) {
  const image::Image im =
      image::read_image(path, std::uint64_t{kMaxApertureImageSide} * kMaxApertureImageSide * 3);
  auto t = std::make_shared<Aperture::ImageTables>();
  const int w = t->w = im.width(), h = t->h = im.height();
  t->pixel_x = 2.0f / static_cast<float>(w), t->pixel_y = 2.0f / static_cast<float>(h);
  if (w > kMaxApertureImageSide || h > kMaxApertureImageSide)
    throw Error("lens: the aperture image " + path + " is larger than " +
                std::to_string(kMaxApertureImageSide) + " pixels a side");
  // Cumulative sums in double (a 4096^2 image's total), stored normalised.
  std::vector<double> rows(h + 1, 0.0);
  std::vector<double> cols(static_cast<std::size_t>(h) * (w + 1), 0.0);
  for (int y = 0; y < h; ++y) {
    double* c = &cols[static_cast<std::size_t>(y) * (w + 1)];
    for (int x = 0; x < w; ++x) {
      double v = 0.0;
      for (int k = 0; k < im.channels(); ++k) v += im.at(x, y, k);
      v = std::isfinite(v) ? std::max(0.0, v / im.channels()) : 0.0;
      c[x + 1] = c[x] + v;
    }
    rows[y + 1] = rows[y] + c[w];
  }
  if (!(rows.back() > 0.0))
    throw Error("lens: the aperture image " + path + " transmits no light (all black)");
  for (double v : rows) t->row_cdf.push_back(static_cast<float>(v / rows.back()));
  t->column_cdf.resize(cols.size());
  t->columns.resize(h);
  t->rows.build(t->row_cdf.data(), h);
  for (int y = 0; y < h; ++y) {
    const std::size_t o = static_cast<std::size_t>(y) * (w + 1);
    const double total = cols[o + w];
    for (int x = 0; x <= w; ++x)
      t->column_cdf[o + x] = total > 0.0 ? static_cast<float>(cols[o + x] / total)
                                         : static_cast<float>(x) / w;
    const float row_share = t->row_cdf[y + 1] - t->row_cdf[y];
    for (int x = 0; x < w; ++x)
      t->peak = std::max(t->peak, row_share * (t->column_cdf[o + x + 1] - t->column_cdf[o + x]));
    if (row_share > 0.0f) t->columns[y].build(&t->column_cdf[o], w);
    t->steps = std::max(t->steps, t->columns[y].steps);
  }
  t->steps = std::max(t->steps, t->rows.steps);
  if (t->steps > BinSampler::kMaxFixedSteps) t->steps = BinSampler::kMaxFixedSteps + 1;
  return t;
}

// One image's tables per file, shared while any Aperture holds them: a preview or a sequence
// constructs cameras again and again with the same lens. Keyed by the path, the file's size and
// its modification time, so an edited image is read again.
std::shared_ptr<const Aperture::ImageTables> load_image_tables(const std::string& path) {
  static core::SharedCache<Aperture::ImageTables> loaded;
  const auto key = core::file_version_key(path);
  if (!key) return build_image_tables(path);  // read_image gives the one-line error
  return loaded.get(*key, [&] { return build_image_tables(path); });
}

}  // namespace

Aperture::Aperture(const ApertureShape& shape) : shape_(shape) {
  shape_.validate();
  squeeze_ = glm::vec2(static_cast<float>(std::min(1.0, 1.0 / shape_.anamorphic_ratio)),
                       static_cast<float>(std::min(1.0, shape_.anamorphic_ratio)));
  if (!shape_.image.empty()) {
    image_ = load_image_tables(shape_.image);
    return;
  }
  if (shape_.blades == 0) return;
  // The rim's points: the corners, and for rounded blades kRimSegments chords on each side of
  // every edge's normal (the rim there is curved; chords of a convex rim stay inside it).
  const int n = shape_.blades;
  const int per_blade = shape_.roundness == 0.0 ? 1 : 2 * kRimSegments;
  const double first = radians(shape_.rotation_deg);
  for (int j = 0; j <= n * per_blade; ++j) {
    const double angle = first + 2.0 * kPi * j / (n * per_blade);
    const double r = polygon_rim(angle);
    rim_points_.push_back(glm::vec2(static_cast<float>(r * std::cos(angle)),
                                    static_cast<float>(r * std::sin(angle))) *
                          squeeze_);
  }
  double total = 0.0;
  std::vector<double> cumulative = {0.0};
  for (std::size_t j = 0; j + 1 < rim_points_.size(); ++j) {
    const glm::vec2 p = rim_points_[j], q = rim_points_[j + 1];
    total += 0.5 * (double(p.x) * q.y - double(p.y) * q.x);
    cumulative.push_back(total);
  }
  for (double c : cumulative) area_cdf_.push_back(static_cast<float>(c / total));
  area_cdf_.back() = 1.0f;
}

double Aperture::polygon_rim(double angle) const {
  if (shape_.blades == 0) return 1.0;
  const int n = shape_.blades;
  const double sector = 2.0 * kPi / n;
  // The angle from the nearest edge's normal (edge normals lie half a sector from the corners).
  double t = std::fmod(angle - radians(shape_.rotation_deg) - 0.5 * sector, sector);
  if (t < 0) t += sector;
  if (t > 0.5 * sector) t -= sector;
  return (1.0 - shape_.roundness) * std::cos(kPi / n) / std::cos(t) + shape_.roundness;
}

glm::vec2 Aperture::sample_image(glm::vec2 u) const {
  const ImageTables& t = *image_;
  const auto [row, fy] = t.rows.invert(u.y, t.steps);
  const auto [col, fx] = t.columns[row].invert(u.x, t.steps);
  // Pixel (col, row) covers [col, col + 1) x [row, row + 1) of the square [-1, 1]^2, top row up.
  return {(static_cast<float>(col) + fx) * t.pixel_x - 1.0f,
          1.0f - (static_cast<float>(row) + fy) * t.pixel_y};
}

float Aperture::transmission_at(glm::vec2 p) const {
  // A pixel's grey level is proportional to its share of the total: its row's share times its
  // share of the row.
  const ImageTables& t = *image_;
  const int x = static_cast<int>(std::floor((p.x + 1.0f) * 0.5f * t.w));
  const int y = static_cast<int>(std::floor((1.0f - p.y) * 0.5f * t.h));
  if (x < 0 || y < 0 || x >= t.w || y >= t.h) return 0.0f;
  const std::size_t o = static_cast<std::size_t>(y) * (t.w + 1);
  const float share = (t.row_cdf[y + 1] - t.row_cdf[y]) * (t.column_cdf[o + x + 1] - t.column_cdf[o + x]);
  return share > 0.0f ? std::min(1.0f, share / t.peak) : 0.0f;
}

double Aperture::rim(double angle) const {
  // The unsqueezed direction that the squeeze turns into `angle`, and the squeezed rim point's
  // distance.
  const double sx = squeeze_.x, sy = squeeze_.y;
  const double b = std::atan2(std::sin(angle) / sy, std::cos(angle) / sx);
  const double r = polygon_rim(b);
  return r * std::hypot(sx * std::cos(b), sy * std::sin(b));
}

bool Aperture::contains(glm::vec2 p) const {
  const double x = p.x / squeeze_.x, y = p.y / squeeze_.y;
  if (image_)
    return transmission_at(glm::vec2(static_cast<float>(x), static_cast<float>(y))) > 0.0f;
  return std::hypot(x, y) <= polygon_rim(std::atan2(y, x));
}

double Aperture::pass(glm::vec2 p) const {
  const double x = p.x / squeeze_.x, y = p.y / squeeze_.y;
  const double r = std::sqrt(x * x + y * y);
  double t = 1.0, rho = r;
  if (image_) {
    t = transmission_at(glm::vec2(static_cast<float>(x), static_cast<float>(y)));
    rho = std::min(1.0, r);  // as sample() gives it
  } else if (shape_.blades != 0) {
    const double rim = polygon_rim(std::atan2(y, x));
    if (r > rim) return 0.0;
    rho = r / rim;
  } else if (r > 1.0) {
    return 0.0;
  }
  if (shape_.weighted()) t *= shape_.transmission(rho) * (1.0 - 0.5 * shape_.profile_strength);
  return t;
}

glm::vec2 Aperture::sample(glm::vec2 u, float* rho) const {
  if (image_) {
    const glm::vec2 p = sample_image(u);
    if (rho) *rho = std::min(1.0f, std::sqrt(p.x * p.x + p.y * p.y));
    return p * squeeze_;
  }
  if (shape_.blades == 0) {
    const glm::vec2 d = concentric_disk(u);
    if (rho) *rho = std::sqrt(d.x * d.x + d.y * d.y);
    return d * squeeze_;
  }
  // The concentric mapping's polar form picks the direction (as a share of the area, the fan's
  // turn) and the distance: the square's strata stay compact on the polygon, as on the disc.
  // (u.x as the share and sqrt(u.y) as the distance is uniform too, but stretches strata into
  // thin wedges: 3-5 % more relMSE on the colour bars through six blades at 4-8 lens samples.)
  const DiskPolar d = concentric_polar(u);
  // The triangle holding the turn's share of the area: the fan's areas differ little, so it lies
  // near the turn's own index.
  const int m = static_cast<int>(area_cdf_.size()) - 1;
  int i = std::min(static_cast<int>(d.turn * static_cast<float>(m)), m - 1);
  while (i > 0 && area_cdf_[i] > d.turn) --i;
  while (i < m - 1 && area_cdf_[i + 1] <= d.turn) ++i;
  const float share = area_cdf_[i + 1] - area_cdf_[i];
  const float along =
      share > 0.0f ? std::clamp((d.turn - area_cdf_[i]) / share, 0.0f, 1.0f) : 0.0f;
  // Uniform in the triangle (centre, rim point i, rim point i + 1): the disc's distance is
  // distributed as sqrt of a uniform number.
  const float r = d.radius;
  if (rho) *rho = r;
  return r * ((1.0f - along) * rim_points_[i] + along * rim_points_[i + 1]);
}

}  // namespace dofcache::lens
