// The occlusion fix through shaped lenses (docs/lens.md): the fix's own scene (a defocused red
// square hiding a green patch in front of an in-focus grey background) previewed through each
// lens with and without the fix, against what that lens sees (computed here: the aperture's share
// of the square around each pixel, over the background behind it). Prints and writes the error
// in the ring around the square's edge and the post-process times; with --figure FILE, the
// six-blade previews and the lens's view side by side.
//
//   build/bench/shaped_occlusion_bench [--width 160] [--repeats 5] [--figure FILE]
#include <algorithm>
#include <cmath>
#include <cstdio>

#include <CLI/CLI.hpp>

#include "bench_common.h"
#include "dofcache/image/image_io.h"
#include "dofcache/lens/aperture.h"
#include "dofcache/preview/preview.h"
#include "dofcache/preview/synthetic_scene.h"

using namespace dofcache;

namespace {

struct Options {
  int width = 160, threads = 0, repeats = 5;
  std::string results = "shaped_occlusion", figure;
};

struct Square {
  int size, lo, hi;  // the square [lo, hi)^2 in a size x size image
  double radius;     // its circle of confusion's radius in pixels
  bool inside(int x, int y) const { return x >= lo && x < hi && y >= lo && y < hi; }
  int distance_to_edge(int x, int y) const {
    if (inside(x, y)) return std::min({x - lo, hi - 1 - x, y - lo, hi - 1 - y});
    return std::max(std::max({lo - x, x - (hi - 1), 0}), std::max({lo - y, y - (hi - 1), 0}));
  }
};

preview::SyntheticScene square_scene(const Square& q) {
  preview::SyntheticScene s;
  s.width = s.height = q.size;
  s.imaging = preview::demo_imaging(q.size);
  const double depth = s.imaging.depth_for_signed_coc(-2.0 * q.radius);
  s.rects.push_back(preview::flat_rect(q.lo, q.lo, q.hi, q.hi, depth, 2, 1.0f, 0.0f, 0.0f));
  s.rects.push_back(preview::flat_rect(q.lo, q.lo, q.hi, q.hi, 3.01, 1, 0.0f, 1.0f, 0.0f));
  s.rects.push_back(preview::flat_rect(0, 0, q.size, q.size, 3.01, 0, 0.5f, 0.5f, 0.5f));
  return s;
}

// What the lens sees: the background is in focus, so a pixel sees its own background point
// through the part of the aperture (scaled to the square's circle of confusion) the square does
// not block.
image::Image lens_view(const Square& q, const lens::ApertureShape& shape) {
  const lens::Aperture aperture(shape);
  std::vector<std::pair<int, int>> offsets;
  const int r = static_cast<int>(std::ceil(q.radius)) + 1;
  for (int dy = -r; dy <= r; ++dy)
    for (int dx = -r; dx <= r; ++dx)
      if (aperture.contains(glm::vec2(dx, dy) / static_cast<float>(q.radius)))
        offsets.emplace_back(dx, dy);
  image::Image out(q.size, q.size, 3);
  for (int y = 0; y < q.size; ++y)
    for (int x = 0; x < q.size; ++x) {
      int covered = 0;
      for (const auto& [dx, dy] : offsets) covered += q.inside(x + dx, y + dy);
      const float c = static_cast<float>(covered) / static_cast<float>(offsets.size());
      const bool patch = q.inside(x, y);
      out.at(x, y, 0) = c + (1 - c) * (patch ? 0.0f : 0.5f);
      out.at(x, y, 1) = (1 - c) * (patch ? 1.0f : 0.5f);
      out.at(x, y, 2) = (1 - c) * (patch ? 0.0f : 0.5f);
    }
  return out;
}

double ring_mse(const Square& q, const image::Image& a, const image::Image& b) {
  double sum = 0;
  int n = 0;
  for (int y = 0; y < q.size; ++y)
    for (int x = 0; x < q.size; ++x)
      if (q.distance_to_edge(x, y) <= static_cast<int>(q.radius) + 2) {
        for (int c = 0; c < 3; ++c) sum += std::pow(a.at(x, y, c) - b.at(x, y, c), 2);
        ++n;
      }
  return sum / n;
}

// Nearest-neighbour enlargement and a row of tiles with a 4-pixel white gap.
image::Image side_by_side(const std::vector<image::Image>& tiles, int scale) {
  const int w = tiles[0].width() * scale, h = tiles[0].height() * scale, gap = 4;
  image::Image out(static_cast<int>(tiles.size()) * (w + gap) - gap, h, 3, 1.0f);
  for (std::size_t t = 0; t < tiles.size(); ++t)
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < 3; ++c)
          out.at(static_cast<int>(t) * (w + gap) + x, y, c) = tiles[t].at(x / scale, y / scale, c);
  return out;
}

int run(const Options& o) {
  const Square q{o.width, o.width * 5 / 16, o.width * 11 / 16, o.width / 16.0};
  const preview::SyntheticScene scene = square_scene(q);
  preview::PreviewOptions options;
  options.threads = o.threads;
  const preview::PreviewInputs base = scene.pinhole_with_revealed_layers(options);
  struct Lens {
    const char* name;
    lens::ApertureShape shape;
  };
  lens::ApertureShape oval;
  oval.anamorphic_ratio = 1.8;
  const std::vector<Lens> lenses = {{"round (layered)", {}},
                                    {"6 blades", {6, 0.0, 0.0, 1.0}},
                                    {"5 blades at 15 deg", {5, 15.0, 0.0, 1.0}},
                                    {"anamorphic 1.8", oval}};
  bench::Table table({"lens", "ring MSE without the fix", "with the fix", "ratio",
                      "post-process without [ms]", "with [ms]"});
  std::vector<image::Image> figure;
  for (const Lens& l : lenses) {
    preview::PreviewInputs in = base;
    in.imaging.lens.aperture = l.shape;
    const image::Image truth = lens_view(q, l.shape);
    image::Image images[2];
    double ms[2] = {1e30, 1e30};
    for (int r = 0; r < o.repeats; ++r)
      for (int fix = 0; fix < 2; ++fix) {  // interleaved
        preview::PreviewTimings t;
        images[fix] = preview::render_preview(
            in, fix ? preview::PreviewMethod::LayeredOcclusion : preview::PreviewMethod::Layered,
            options, &t);
        ms[fix] = std::min(ms[fix], t.total_ms);
      }
    const double without = ring_mse(q, images[0], truth), with = ring_mse(q, images[1], truth);
    table.add_row({l.name, bench::Table::Cell(without, 5), bench::Table::Cell(with, 5),
                   bench::Table::Cell(with / without, 3), bench::Table::Cell(ms[0], 1),
                   bench::Table::Cell(ms[1], 1)});
    if (l.shape.blades == 6) figure = {images[0], images[1], truth};
  }
  std::printf("The occlusion fix's square scene at %dx%d (circle of confusion %.0f px), previews "
              "against what each lens sees, in the ring within %d px of the square's edge; the "
              "fastest of %d interleaved runs\n",
              q.size, q.size, q.radius, static_cast<int>(q.radius) + 2, o.repeats);
  table.print();
  if (!o.figure.empty()) {
    image::write_image(o.figure, side_by_side(figure, 2));
    std::printf("wrote %s (six blades: without the fix, with it, what the lens sees)\n",
                o.figure.c_str());
  }
  bench::write_table(o.results, table, {{"width", q.size}, {"coc_radius", q.radius}});
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{"The occlusion fix through shaped lenses: previews with and without it against "
               "what the lens sees, on the fix's square scene.",
               "shaped_occlusion_bench"};
  bench::add_common_options(app, o.width, o.threads, o.results);
  bench::add_count_option(app, "--repeats", o.repeats, "Interleaved runs (the fastest is kept)");
  app.add_option("--figure", o.figure, "Write the six-blade previews and the lens's view here (PNG)");
  bench::parse_command_line(app, argc, argv);
  return bench::run_guarded(app, [&] { return run(o); });
}
