// Scatter (forward-mapping) baseline: depth-binned disk splats through per-row difference
// buffers, bins composited far to near (see baselines.h); and the shaped scatter, which splats
// the lens's own bokeh (preview.h).
#include <algorithm>
#include <cmath>

#include "aperture_rows.h"
#include "dofcache/render/camera.h"
#include "pipeline.h"

namespace dofcache::preview::detail {

namespace {
constexpr int kBandRows = 8;
constexpr int kMaxBins = 128;
constexpr float kQuantum = 16.0f;  // splat radii are quantised to 1/16 px

// Half-width of the discrete disk {dx^2 + dy^2 <= (r + 1/2)^2} on row dy.
inline int half_width(float r2, int dy) {
  return static_cast<int>(std::sqrt(std::max(0.0f, r2 - static_cast<float>(dy * dy))));
}

// The splats sorted into depth bins of signed CoC: bin b holds sorted[start[b] .. start[b + 1]),
// in scan order (so by row), or in the order `order` lists them (which must be by row).
struct Bins {
  int count = 0;
  const int* sorted = nullptr;
  const int* start = nullptr;
};

Bins sort_into_bins(const float* C, size_t N, const PreviewOptions& options,
                    PreviewWorkspace::Impl& ws, const int* order = nullptr) {
  float cmin = C[0], cmax = C[0];
  for (size_t p = 1; p < N; ++p) {
    cmin = std::min(cmin, C[p]);
    cmax = std::max(cmax, C[p]);
  }
  const double span = static_cast<double>(cmax) - cmin;
  const double bin_width = std::max({options.scatter_bin_width, span / (kMaxBins - 0.5), 1e-6});
  const int bins = std::min(kMaxBins, static_cast<int>(span / bin_width) + 1);
  std::vector<int>& bin_of = ws.bin_pixels;  // the sorted list, then each pixel's bin
  ensure_size(bin_of, 2 * N);
  int* bin_index = bin_of.data() + N;
  for (size_t p = 0; p < N; ++p)
    bin_index[p] = std::min(bins - 1, static_cast<int>((C[p] - cmin) / bin_width));
  // Counting sort by bin; within a bin pixels stay in scan order.
  ws.bin_start.assign(bins + 1, 0);
  for (size_t p = 0; p < N; ++p) ++ws.bin_start[bin_index[p] + 1];
  for (int b = 0; b < bins; ++b) ws.bin_start[b + 1] += ws.bin_start[b];
  std::vector<int> cursor(ws.bin_start.begin(), ws.bin_start.end() - 1);
  for (size_t k = 0; k < N; ++k) {
    const int p = order ? order[k] : static_cast<int>(k);
    bin_of[cursor[bin_index[p]]++] = p;
  }
  return {bins, bin_of.data(), ws.bin_start.data()};
}

// The splats of every bin, far to near, through per-row difference buffers of `Channels` doubles
// a pixel. Bands of rows are independent (each owns its rows of the difference buffer and of the
// composite), so they run in parallel, each going through the bins. reach[b]: the rows from its
// own a splat of bin b can touch. splat(q, r0, r1, diff, ya, yb) adds source q's splat within
// rows [r0, r1) (diff: row r0's buffer) and widens [ya, yb) to the rows it touched;
// composite(y, row) takes row y's differences once the bin is complete. row_of(q): the row source
// q sits on (a bin's sources are in row order): PixelRow where the sources are the pixels.
struct PixelRow {
  int W;
  int operator()(int q) const { return q / W; }
};
template <int Channels, class Splat, class Composite, class RowOf>
void scatter_bins(int W, int H, const Bins& bins, const std::vector<int>& reach,
                  std::vector<double>& buffer, const Splat& splat, const Composite& composite,
                  const RowOf& row_of) {
  const auto before_row = [&](int q, int row) { return row_of(q) < row; };
  const size_t row_len = static_cast<size_t>(W + 1) * Channels;
  ensure_size(buffer, row_len * H);
  const int bands = (H + kBandRows - 1) / kBandRows;
  tbb::parallel_for(
      tbb::blocked_range<int>(0, bands, 1), [&](const tbb::blocked_range<int>& range) {
        for (int band = range.begin(); band < range.end(); ++band) {
          const int r0 = band * kBandRows, r1 = std::min(H, (band + 1) * kBandRows);
          double* diff = buffer.data() + row_len * r0;
          for (int b = bins.count - 1; b >= 0; --b) {  // far to near
            const int* begin = bins.sorted + bins.start[b];
            const int* end = bins.sorted + bins.start[b + 1];
            if (begin == end) continue;
            // Sources whose splats can touch rows [r0, r1).
            const int* first = std::lower_bound(begin, end, std::max(0, r0 - reach[b]), before_row);
            const int* last = std::lower_bound(begin, end, std::min(H, r1 + reach[b]), before_row);
            if (first == last) continue;
            std::fill(diff, diff + row_len * (r1 - r0), 0.0);
            int ya = r1, yb = r0;  // rows this bin touches in the band
            for (const int* s = first; s < last; ++s) splat(*s, r0, r1, diff, ya, yb);
            for (int y = ya; y < yb; ++y) composite(y, diff + row_len * (y - r0));
          }
        }
      });
}

}  // namespace

void scatter_preview(const image::Image& color, const PreviewOptions& options,
                     PreviewWorkspace::Impl& ws, image::Image& out) {
  const int W = color.width(), H = color.height();
  const size_t N = color.pixel_count();
  const float* col = color.data().data();
  const float* C = ws.coc.data();

  // Radii (quantised), bins and splat densities.
  ensure_size(ws.radius, N);
  ensure_size(ws.inv_area, N);
  float max_radius = 0;
  for (size_t p = 0; p < N; ++p) {
    float r = 0.5f * std::abs(C[p]);
    r = r > 0.5f ? std::round(r * kQuantum) / kQuantum : 0.0f;
    ws.radius[p] = r;
    max_radius = std::max(max_radius, r);
  }
  const Bins bins = sort_into_bins(C, N, options, ws);
  // Pixel count of the discrete disk per quantised radius.
  const int quanta = static_cast<int>(max_radius * kQuantum) + 1;
  std::vector<float> inv_count(quanta);
  for (int k = 0; k < quanta; ++k) {
    float r = k / kQuantum, r2 = (r + 0.5f) * (r + 0.5f);
    int e = static_cast<int>(r + 0.5f), count = 0;
    for (int dy = -e; dy <= e; ++dy) count += 2 * half_width(r2, dy) + 1;
    inv_count[k] = 1.0f / count;
  }
  parallel_rows(H, [&](int y0, int y1) {
    for (int y = y0; y < y1; ++y)
      for (int x = 0; x < W; ++x) {
        size_t p = static_cast<size_t>(y) * W + x;
        float r = ws.radius[p];
        int e = static_cast<int>(r + 0.5f);
        if (x >= e && y >= e && x + e < W && y + e < H) {
          ws.inv_area[p] = inv_count[static_cast<int>(r * kQuantum + 0.5f)];
          continue;
        }
        // Near the border: normalise over the part of the disk inside the image, so a splat
        // keeps its full weight (and its bin its full coverage) up to the edge.
        float r2 = (r + 0.5f) * (r + 0.5f);
        int count = 0;
        for (int dy = std::max(-e, -y); dy <= std::min(e, H - 1 - y); ++dy) {
          int hw = half_width(r2, dy);
          count += std::min(x + hw, W - 1) - std::max(x - hw, 0) + 1;
        }
        ws.inv_area[p] = 1.0f / count;
      }
  });
  ensure_size(ws.acc, N);
  std::fill(ws.acc.begin(), ws.acc.begin() + N, Rgba{0, 0, 0, 0});

  // Per bin: the largest splat extent.
  std::vector<int> reach(bins.count, 0);
  for (int b = 0; b < bins.count; ++b)
    for (int k = bins.start[b]; k < bins.start[b + 1]; ++k)
      reach[b] = std::max(reach[b], static_cast<int>(ws.radius[bins.sorted[k]] + 0.5f));

  constexpr int kCh = 4;
  const size_t row_len = static_cast<size_t>(W + 1) * kCh;
  scatter_bins<kCh>(
      W, H, bins, reach, ws.diff,
      [&](int q, int r0, int r1, double* diff, int& ya, int& yb) {
        const int qy = q / W, qx = q % W;
        const float r = ws.radius[q], r2 = (r + 0.5f) * (r + 0.5f);
        const int e = static_cast<int>(r + 0.5f);
        const int dy0 = std::max(-e, r0 - qy), dy1 = std::min(e, r1 - 1 - qy);
        if (dy0 > dy1) return;
        ya = std::min(ya, qy + dy0);
        yb = std::max(yb, qy + dy1 + 1);
        const double ia = ws.inv_area[q];
        const double v[kCh] = {col[3 * q] * ia, col[3 * q + 1] * ia, col[3 * q + 2] * ia, ia};
        for (int dy = dy0; dy <= dy1; ++dy) {
          const int hw = half_width(r2, dy);
          double* row = diff + row_len * (qy + dy - r0);
          double* a = row + kCh * std::max(qx - hw, 0);
          double* z = row + kCh * (std::min(qx + hw, W - 1) + 1);
          for (int k = 0; k < kCh; ++k) {
            a[k] += v[k];
            z[k] -= v[k];
          }
        }
      },
      // Prefix sums give the bin's splat sums; composite them over what lies behind.
      [&](int y, const double* row) {
        Rgba* accrow = ws.acc.data() + static_cast<size_t>(y) * W;
        double sum[kCh] = {0, 0, 0, 0};
        for (int x = 0; x < W; ++x) {
          for (int k = 0; k < kCh; ++k) sum[k] += row[kCh * x + k];
          if (sum[3] <= 1e-9) continue;
          const float alpha = static_cast<float>(std::min(1.0, sum[3]));
          const double scale = alpha / sum[3];
          Rgba src{static_cast<float>(sum[0] * scale), static_cast<float>(sum[1] * scale),
                   static_cast<float>(sum[2] * scale), alpha};
          accrow[x] = src + accrow[x] * (1.0f - alpha);
        }
      },
      PixelRow{W});

  float* o = out.data().data();
  parallel_rows(H, [&](int y0, int y1) {
    for (size_t p = static_cast<size_t>(y0) * W; p < static_cast<size_t>(y1) * W; ++p) {
      const Rgba& a = ws.acc[p];
      float inv = a.a > 0 ? 1.0f / a.a : 0.0f;
      o[3 * p] = a.r * inv;
      o[3 * p + 1] = a.g * inv;
      o[3 * p + 2] = a.b * inv;
    }
  });
}

namespace {
// One colour band's splat of a pixel: its bokeh's centre (film pixels), signed scale (pixels per
// aperture unit, clamped to the largest radius), tilt term and the discs of the vignetting stop or
// of a real lens's rims (aperture units), as render::BokehSpot.
struct ShapedSplat {
  float cx, cy, scale;
  float tilt_x, tilt_y;
  render::StopDisc stops[2];
  bool normalised = false;  // the image is divided by what the stops pass (BokehSpot)
  float weight = 0.0f;  // coverage per pixel (times the run's density): one over the shape's
                        // pixels in the image; 0: drawn as a sharp splat
  float light = 1.0f;   // light per pixel: one over the transmission's pixels (cut by the stops
                        // where the image is normalised for them); sharp: the share of the
                        // aperture's light that the stops let through

  bool sharp() const { return std::abs(scale) <= 0.5f; }
  bool stopped() const { return stops[0].present() || stops[1].present(); }
  // How far from its centre the shape reaches (pixels): the aperture within the unit square, a
  // pixel's half, and the tilt's stretch.
  float extent() const {
    const float t = std::min(0.9f, std::hypot(tilt_x, tilt_y));
    return (std::abs(scale) + 0.5f) / (1.0f - t);
  }
};

// The film pixels of a splat's shape (not sharp), row by row: f(y, x0, x1, density) for each run
// [x0, x1] within the image's columns and rows [row_begin, row_end), cut to the stops' discs if
// `cut`. `density` is 1 untilted; tilted,
// the map's Jacobian (scale^2 / (1 + a . tilt)^3) spreads the aperture's uniform rays unevenly,
// and the run's pixels get (1 + a . tilt)^3 of them. The film offset o (y up) of aperture point
// a is scale a / (1 + a . tilt) (render::BokehSpot), and the shape is padded by half a pixel as
// the disk scatter's (r + 1/2). A row's aperture height is exact for a tilt about the
// horizontal axis; a tilt about the vertical one bends the row's image, which the row's centre
// stands for.
template <class F>
void for_each_run(const ShapedSplat& s, const ApertureRows& rows, int W, int row_begin,
                  int row_end, bool cut, const F& f) {
  const float e = s.extent();
  const int y0 = std::max(row_begin, static_cast<int>(std::ceil(s.cy - 0.5f - e)));
  const int y1 = std::min(row_end - 1, static_cast<int>(std::floor(s.cy - 0.5f + e)));
  const bool stopped = cut && s.stopped();
  for (int y = y0; y <= y1; ++y) {
    const float oy = s.cy - 0.5f - static_cast<float>(y);
    const float d = s.scale - oy * s.tilt_y;  // a = o / (scale - o . tilt), on this row
    const float rs = std::abs(d) + 0.5f, sign = d < 0.0f ? -1.0f : 1.0f;
    const float ay = sign * oy / rs;
    float lo = -2.0f, hi = 2.0f;  // the row's chord through the stops' discs
    if (stopped) {
      for (const render::StopDisc& disc : s.stops) {
        if (!disc.present()) continue;
        const float h2 = disc.radius * disc.radius - (ay - disc.centre.y) * (ay - disc.centre.y);
        if (h2 < 0.0f) lo = 2.0f;
        const float h = std::sqrt(std::max(0.0f, h2));
        lo = std::max(lo, disc.centre.x - h);
        hi = std::min(hi, disc.centre.x + h);
      }
      if (lo > hi) continue;
    }
    for (const ApertureSpan* span = rows.begin(ay); span != rows.end(ay); ++span) {
      float a0 = span->x0, a1 = span->x1;
      if (stopped) {
        a0 = std::max(a0, lo);
        a1 = std::min(a1, hi);
        if (a0 > a1) continue;
      }
      const float o0 = sign * rs * a0 / (1.0f + a0 * s.tilt_x);
      const float o1 = sign * rs * a1 / (1.0f + a1 * s.tilt_x);
      const float lo = s.cx + std::min(o0, o1), hi = s.cx + std::max(o0, o1);
      const int x0 = std::max(0, static_cast<int>(std::ceil(lo - 0.5f)));
      const int x1 = std::min(W - 1, static_cast<int>(std::floor(hi - 0.5f)));
      const float j = 1.0f + ay * s.tilt_y + 0.5f * (a0 + a1) * s.tilt_x;
      if (x0 <= x1) f(y, x0, x1, j * j * j);
    }
  }
}

// A sharp splat: the pixels around its centre, weighted bilinearly (so a colour band's
// sub-pixel shift shows): f(y, x, weight), the weights of the pixels in the image adding up to 1.
template <class F>
void for_each_bilinear(const ShapedSplat& s, int W, int H, const F& f) {
  const float fx = s.cx - 0.5f, fy = s.cy - 0.5f;
  const int x0 = static_cast<int>(std::floor(fx)), y0 = static_cast<int>(std::floor(fy));
  const float tx = fx - static_cast<float>(x0), ty = fy - static_cast<float>(y0);
  const float w[4] = {(1 - tx) * (1 - ty), tx * (1 - ty), (1 - tx) * ty, tx * ty};
  float total = 0.0f;
  for (int k = 0; k < 4; ++k) {
    const int x = x0 + (k & 1), y = y0 + (k >> 1);
    if (x >= 0 && y >= 0 && x < W && y < H) total += w[k];
  }
  if (total <= 0.0f) return;
  for (int k = 0; k < 4; ++k) {
    const int x = x0 + (k & 1), y = y0 + (k >> 1);
    if (x >= 0 && y >= 0 && x < W && y < H && w[k] > 0.0f) f(y, x, w[k] / total);
  }
}
}  // namespace

namespace {
// The shaped scatter (preview.h) of one image: every pixel splats the lens's bokeh where the lens
// puts it, and so does every surface the occlusion fix revealed behind it (the inputs' revealed
// layers: what a lens sees past a blurred foreground's rim, which the pinhole image hides). Splats
// go into depth bins composited far to near, so a revealed surface shows where the splats in
// front of it leave coverage, as in the layered method with the fix. A splat's geometry is the
// camera's (BokehSpot), found again wherever it is drawn, so only its two weights are kept per
// splat and band (8 bytes rather than the 60 of the whole). Splats 0 .. N-1 are the pixels,
// N .. on the revealed fragments.
class ShapedScatter {
 public:
  ShapedScatter(const PreviewInputs& inputs, const PreviewOptions& options, bool revealed)
      : inputs_(inputs), options_(options), W_(inputs.color.width()), H_(inputs.color.height()),
        N_(inputs.color.pixel_count()),
        camera_(glm::mat4(1.0f), static_cast<float>(inputs.imaging.yfov), inputs.imaging.lens,
                W_, H_),
        levels_(camera_.aperture()),
        bands_(inputs.imaging.lens.aperture.chromatic() ? 3 : 1),
        limit_(static_cast<float>(options.max_coc_radius)) {
    if (revealed) add_fragments(inputs.revealed);
  }

  void run(PreviewWorkspace::Impl& ws, image::Image& out) {
    weigh();
    const float* coc = ws.coc.data();
    std::vector<float> with_fragments;  // the pixels' CoCs, then the fragments', as compute_coc's
    std::vector<int> order;  // every row's pixels, then the fragments behind them: sources by row
    if (!fragments_.empty()) {
      with_fragments.assign(ws.coc.begin(), ws.coc.begin() + static_cast<std::ptrdiff_t>(N_));
      const CocMap coc_of(inputs_.imaging, options_.max_coc_radius);
      for (const Fragment& f : fragments_) with_fragments.push_back(coc_of(f.depth));
      coc = with_fragments.data();
      order.reserve(splats());
      std::size_t f = 0;
      for (int y = 0; y < H_; ++y) {
        for (int x = 0; x < W_; ++x) order.push_back(y * W_ + x);
        for (; f < fragments_.size() && fragments_[f].y == y; ++f)
          order.push_back(static_cast<int>(N_ + f));
      }
    }
    const Bins bins =
        sort_into_bins(coc, splats(), options_, ws, order.empty() ? nullptr : order.data());
    draw(bins, ws);
    resolve(ws, out);
  }

  std::size_t fragments() const { return fragments_.size(); }

 private:
  static constexpr int kCh = 6;  // colour and alpha per channel: chromatic bands cover differently

  // A surface the occlusion fix revealed behind pixel (x, y).
  struct Fragment {
    int x, y;
    float depth;
    float colour[3];
  };
  // The revealed layers' surfaces, by row.
  void add_fragments(const std::vector<RevealedLayer>& layers) {
    for (const RevealedLayer& r : layers) {
      check_revealed_layer_size(r, W_, H_);
      for (int y = 0; y < r.mask.height(); ++y)
        for (int x = 0; x < r.mask.width(); ++x)
          if (r.mask.at(x, y, 0) > 0.0f)
            fragments_.push_back({x, y, r.depth.at(x, y, 0),
                                  {r.color.at(x, y, 0), r.color.at(x, y, 1), r.color.at(x, y, 2)}});
    }
    std::stable_sort(fragments_.begin(), fragments_.end(),
                     [](const Fragment& a, const Fragment& b) { return a.y < b.y; });
  }
  std::size_t splats() const { return N_ + fragments_.size(); }
  int row_of(std::size_t p) const {
    return p < N_ ? static_cast<int>(p / W_) : fragments_[p - N_].y;
  }
  const float* colour_of(std::size_t p) const {
    return p < N_ ? inputs_.color.data().data() + 3 * p : fragments_[p - N_].colour;
  }

  // Splat p's geometry in `band` (-1 without colour bands), its weights left unset.
  ShapedSplat geometry(std::size_t p, int band) const {
    double z = p < N_ ? inputs_.depth.data()[p] : fragments_[p - N_].depth;
    if (!(z > 0.0)) z = std::isnan(z) ? 1e30 : 1e-9;  // a miss is far; at the lens, near
    if (std::isinf(z)) z = 1e30;
    const int x = p < N_ ? static_cast<int>(p % W_) : fragments_[p - N_].x;
    const render::BokehSpot spot = camera_.bokeh({x + 0.5f, row_of(p) + 0.5f}, z, band);
    return {spot.centre.x,
            spot.centre.y,
            std::clamp(spot.scale, -limit_, limit_),
            spot.tilt.x,
            spot.tilt.y,
            {spot.stops[0], spot.stops[1]},
            spot.normalised};
  }
  ShapedSplat splat(std::size_t p, int b) const {
    ShapedSplat s = geometry(p, bands_ == 3 ? b : -1);
    const Weights& w = weights_[p * bands_ + b];
    s.weight = w.weight, s.light = w.light;
    return s;
  }

  // A splat's pixels in the image (times the tilt's density) over `rows`, cut by its stops.
  double pixels(const ShapedSplat& s, const ApertureRows& rows, bool cut) const {
    double inside = 0;
    for_each_run(s, rows, W_, 0, H_, cut,
                 [&](int, int x0, int x1, float j) { inside += (x1 - x0 + 1) * j; });
    return inside;
  }
  // The light's pixels: every level's, each weighing its step of the transmission.
  double lit(const ShapedSplat& s, bool cut) const {
    double n = 0;
    for (int k = 0; k < levels_.count(); ++k)
      n += levels_.weight(k) * pixels(s, levels_.level(k), cut);
    return n;
  }

  // Every splat's weights: normalised over its part inside the image, as the disk scatter's; a
  // shape too small to cover a pixel centre is drawn as a sharp one.
  void weigh() {
    weights_.assign(splats() * bands_, Weights{});
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, splats(), 1024), [&](const auto& range) {
      for (std::size_t p = range.begin(); p < range.end(); ++p)
        for (int b = 0; b < bands_; ++b) {
          const ShapedSplat s = geometry(p, bands_ == 3 ? b : -1);
          Weights& w = weights_[p * bands_ + b];
          const double inside = s.sharp() ? 0.0 : pixels(s, levels_.shape(), false);
          if (inside > 0.0) {
            w.weight = static_cast<float>(1.0 / inside);
            // A graded splat whole in the frame: its levels' pixels as the shape's times the
            // transmission's mean (within a pixel's rounding of each level's rim), which saves
            // a pass per level; at the frame's border, counted.
            const float e = s.extent();
            const bool whole = s.cx - e >= 0.0f && s.cy - e >= 0.0f &&
                               s.cx + e <= static_cast<float>(W_) &&
                               s.cy + e <= static_cast<float>(H_);
            const double all = levels_.count() == 1 ? inside
                               : whole              ? inside * levels_.mean()
                                                    : lit(s, false);
            w.light = all > 0.0 ? static_cast<float>(1.0 / all) : 0.0f;
            if (s.normalised && s.stopped()) {
              const double passed = lit(s, true);
              if (passed > 0.0) w.light = static_cast<float>(1.0 / passed);
            }
          } else if (s.stopped() && !s.normalised) {
            w.light = levels_.area_share(s.stops);
          }
        }
    });
  }

  // Per bin: the rows from its own that a splat of the bin can touch.
  std::vector<int> reaches(const Bins& bins) const {
    std::vector<int> reach(bins.count, 0);
    tbb::parallel_for(0, bins.count, [&](int b) {
      for (int k = bins.start[b]; k < bins.start[b + 1]; ++k) {
        const int q = bins.sorted[k], qy = row_of(static_cast<std::size_t>(q));
        for (int band = 0; band < bands_; ++band) {
          const ShapedSplat s = geometry(static_cast<std::size_t>(q), bands_ == 3 ? band : -1);
          const float off = std::abs(s.cy - (static_cast<float>(qy) + 0.5f));
          reach[b] = std::max(reach[b], static_cast<int>(std::ceil(off + s.extent() + 1.0f)));
        }
      }
    });
    return reach;
  }

  // Source q's splats within rows [r0, r1) (diff: row r0's difference buffer), widening [ya, yb)
  // to the rows they touch.
  void draw_splats(int q, int r0, int r1, double* diff, int& ya, int& yb) const {
    const float* col = colour_of(static_cast<std::size_t>(q));
    const std::size_t row_len = static_cast<std::size_t>(W_ + 1) * kCh;
    const ApertureRows& shape = levels_.shape();
    for (int band = 0; band < bands_; ++band) {
      const ShapedSplat s = splat(static_cast<std::size_t>(q), band);
      // Colour and alpha per unit of weight.
      double colour[kCh] = {0, 0, 0, 0, 0, 0}, alpha[kCh] = {0, 0, 0, 0, 0, 0};
      for (int c = 0; c < 3; ++c)
        if (bands_ == 1 || c == band) {
          colour[c] = col[c];
          alpha[3 + c] = 1.0;
        }
      auto add = [&](const double* v, int y, int x0, int x1, double w) {
        if (y < r0 || y >= r1) return;  // (the runs are clipped already; bilinear ones not)
        ya = std::min(ya, y);
        yb = std::max(yb, y + 1);
        double* row = diff + row_len * (y - r0);
        double* a = row + kCh * x0;
        double* z = row + kCh * (x1 + 1);
        for (int k = 0; k < kCh; ++k) {
          a[k] += v[k] * w;
          z[k] -= v[k] * w;
        }
      };
      if (s.weight == 0.0f) {  // sharp: its light is what the stop lets through of its bundle
        for (int c = 0; c < 3; ++c) colour[c] *= s.light;
        for (int c = 3; c < kCh; ++c) colour[c] = alpha[c];
        for_each_bilinear(s, W_, H_, [&](int y, int x, float w) { add(colour, y, x, x, w); });
        continue;
      }
      if (!s.stopped() && levels_.count() == 1) {  // colour and alpha over the same runs
        for (int c = 3; c < kCh; ++c) colour[c] = alpha[c];
        for_each_run(s, shape, W_, r0, r1, false, [&](int y, int x0, int x1, float j) {
          add(colour, y, x0, x1, s.weight * j);
        });
        continue;
      }
      // The stopped rays bring no light but their share of the coverage: the splats' alphas
      // then tile as the uncut shapes do, and the light a pixel gathers through the cut ones is
      // its own bundle's share that the stops pass, as in the ray tracer (normalised: the whole
      // of it, as a real lens's image divided by what its rims pass). A graded transmission's
      // light is its levels', its coverage the whole shape's.
      for_each_run(s, shape, W_, r0, r1, false, [&](int y, int x0, int x1, float j) {
        add(alpha, y, x0, x1, s.weight * j);
      });
      for (int k = 0; k < levels_.count(); ++k)
        for_each_run(s, levels_.level(k), W_, r0, r1, s.stopped(),
                     [&](int y, int x0, int x1, float j) {
                       add(colour, y, x0, x1, s.light * levels_.weight(k) * j);
                     });
    }
  }

  // The bins far to near, each composited over what lies behind, per channel.
  void draw(const Bins& bins, PreviewWorkspace::Impl& ws) const {
    std::vector<float>& acc = ws.shaped_acc;
    ensure_size(acc, N_ * kCh);
    std::fill(acc.begin(), acc.begin() + N_ * kCh, 0.0f);
    scatter_bins<kCh>(
        W_, H_, bins, reaches(bins), ws.diff,
        [&](int q, int r0, int r1, double* diff, int& ya, int& yb) {
          draw_splats(q, r0, r1, diff, ya, yb);
        },
        [&](int y, const double* row) {
          float* accrow = acc.data() + static_cast<std::size_t>(y) * W_ * kCh;
          double sum[kCh] = {0, 0, 0, 0, 0, 0};
          for (int x = 0; x < W_; ++x) {
            for (int k = 0; k < kCh; ++k) sum[k] += row[kCh * x + k];
            float* a = accrow + kCh * x;
            for (int c = 0; c < 3; ++c) {
              if (sum[3 + c] <= 1e-9) continue;
              const float alpha = static_cast<float>(std::min(1.0, sum[3 + c]));
              a[c] = static_cast<float>(sum[c] * alpha / sum[3 + c]) + a[c] * (1.0f - alpha);
              a[3 + c] = alpha + a[3 + c] * (1.0f - alpha);
            }
          }
        },
        [&](int q) { return row_of(static_cast<std::size_t>(q)); });
  }

  // Colour over coverage.
  void resolve(const PreviewWorkspace::Impl& ws, image::Image& out) const {
    const std::vector<float>& acc = ws.shaped_acc;
    float* o = out.data().data();
    parallel_rows(H_, [&](int y0, int y1) {
      for (std::size_t p = static_cast<std::size_t>(y0) * W_;
           p < static_cast<std::size_t>(y1) * W_; ++p)
        for (int c = 0; c < 3; ++c) {
          const float a = acc[kCh * p + 3 + c];
          o[3 * p + c] = a > 0.0f ? acc[kCh * p + c] / a : 0.0f;
        }
    });
  }

  struct Weights {
    float weight = 0.0f, light = 1.0f;  // as ShapedSplat's
  };

  const PreviewInputs& inputs_;
  const PreviewOptions& options_;
  const int W_, H_;
  const std::size_t N_;
  std::vector<Fragment> fragments_;
  const render::ThinLensCamera camera_;
  const ApertureLevels levels_;
  const int bands_;
  const float limit_;
  std::vector<Weights> weights_;
};
}  // namespace

std::size_t shaped_scatter_preview(const PreviewInputs& inputs, const PreviewOptions& options,
                                   bool revealed, PreviewWorkspace::Impl& ws, image::Image& out) {
  ShapedScatter scatter(inputs, options, revealed);
  scatter.run(ws, out);
  return scatter.fragments();
}

}  // namespace dofcache::preview::detail
