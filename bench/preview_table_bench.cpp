// The preview mode on the shipped scenes, against the paper's Tables 3.1 and 4.3:
//   1. Table 3.1 again: wall time of each stage of the preview (pinhole render, extra-region mask
//      = near-plane id renders + mask building, extra render of the revealed layers,
//      post-process), for Kraus & Strengert's layered method and the occlusion fix;
//   2. error of every post-process (gather, scatter, Kraus & Strengert, occlusion fix) against a
//      converged DRT reference (uncached, --ref-spp samples, cached in bench/results/references/),
//      over the whole image and over the edge band (below), and what the inputs themselves carry:
//      the band's lens integral traced through them with exact visibility (exact_visibility);
//   3. Table 4.3 again: DRT, DRT with the radiance cache (vdb), Kraus & Strengert, the occlusion
//      fix: time and error;
//   4. refocus at 640x480: loading saved inputs and rerunning the post-process with the same and
//      with another lens, and the post-process alone (2 threads).
// Every stage is run --repeats times, alternating the variants, and the fastest run is kept (the
// machine is shared); totals are sums of the fastest stages. Writes
// bench/results/preview_table.{json,csv} and, with --figures DIR, one comparison image per scene
// (Kraus | occlusion fix | reference over their error maps and the edge band) as
// DIR/preview_<scene>.png.
//
// Edge band: the pixels within max(R_p, R_q) (at least 1 px) of a pair of 4-neighbours p, q whose
// pinhole depths differ so much that their signed CoC diameters differ by more than 1 px (an
// occluding edge, where the blurs of the two sides differ visibly); R = |c| / 2 is the CoC radius
// (eq. (2.6)) of the pinhole depth, clamped as the post-process clamps it.
//
//   preview_table_bench [--width W] [--spp N] [--drt-spp N] [--ref-spp N] [--threads T]
//                       [--repeats K] [--refocus-width W] [--scene FILE]... [--figures DIR]
//                       [--refocus-only 1] [--skip-refocus 1] [--results NAME]
//                       [--direct-blur-radius R] [--exact-rays N]   (--help for more)
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#include <tbb/parallel_for.h>

#include "bench_common.h"
#include "dofcache/cache/radiance_cache.h"
#include "dofcache/core/stopwatch.h"
#include "dofcache/image/image_io.h"
#include "dofcache/image/metrics.h"
#include "dofcache/lens/thin_lens.h"
#include "dofcache/preview/inputs_file.h"
#include "dofcache/preview/occlusion.h"
#include "dofcache/preview/preview_renderer.h"
#include "dofcache/preview/refocus.h"
#include "dofcache/preview/synthetic_scene.h"
#include "dofcache/render/renderer.h"
#include "dofcache/render/setup.h"
#include "dofcache/scene/accel.h"

using namespace dofcache;
namespace fs = std::filesystem;
using preview::PreviewMethod;
using Cell = bench::Table::Cell;

namespace {

struct Options {
  int width = 160, spp = 16, drt_spp = 64, ref_spp = 1024, threads = 0, repeats = 3;
  int refocus_width = 640, refocus_repeats = 15;
  int refocus_only = 0;   // 1: only the refocus timings (section 4)
  int exact_rays = 1024;  // lens rays per band pixel of the exact-visibility row
  std::string figures;
  std::string results = "preview_table";  // results file name (bench/results/<results>.json)
  int skip_refocus = 0;                   // 1: no section 4 (refocus at 640x480)
  double direct_blur_radius = -1;         // >= 0: overrides PreviewOptions::direct_blur_radius
  std::vector<std::string> scenes = {"color_bars.gltf", "color_spheres.gltf", "cornell_box.gltf"};
};

using clock_type = std::chrono::steady_clock;

struct SceneSetup {
  std::string name;
  scene::Scene scene;
  std::unique_ptr<scene::Accel> accel;
  render::RenderSettings base;
  const scene::Camera& camera() const { return scene.cameras[0]; }
};

SceneSetup load(const std::string& file, int width, const Options& o) {
  SceneSetup s;
  s.name = fs::path(file).stem().string();
  s.scene = render::load_scene(bench::scene_path(file));
  s.accel = std::make_unique<scene::Accel>(s.scene);
  s.base = bench::camera_settings(s.scene, *s.accel, s.camera(), width, 16, o.threads);
  return s;
}

// The converged reference: uncached DRT, rendered once and kept as EXR.
image::Image reference(const SceneSetup& s, const Options& o) {
  return bench::converged_reference(s.name, s.scene, *s.accel, s.camera(), s.base, o.ref_spp);
}

// The edge band of the header comment (1 channel, 0/1).
image::Image edge_band(const image::Image& depth, const lens::LensImaging& imaging,
                       const preview::PreviewOptions& options) {
  const int w = depth.width(), h = depth.height();
  preview::CocMap coc(imaging, options.max_coc_radius);
  image::Image c(w, h, 1), band(w, h, 1, 0.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) c.at(x, y, 0) = coc(depth.at(x, y, 0));
  auto stamp = [&](int cx, int cy, double r) {
    const int R = static_cast<int>(std::ceil(r));
    for (int y = std::max(0, cy - R); y <= std::min(h - 1, cy + R); ++y)
      for (int x = std::max(0, cx - R); x <= std::min(w - 1, cx + R); ++x)
        if ((x - cx) * (x - cx) + (y - cy) * (y - cy) <= r * r) band.at(x, y, 0) = 1.0f;
  };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (auto [dx, dy] : {std::pair{1, 0}, std::pair{0, 1}}) {
        if (x + dx >= w || y + dy >= h) continue;
        const double r = preview::occluding_edge_radius(c.at(x, y, 0), c.at(x + dx, y + dy, 0));
        if (r == 0) continue;
        stamp(x, y, r);
        stamp(x + dx, y + dy, r);
      }
  return band;
}

double fraction_set(const image::Image& mask) {
  double n = 0;
  for (float v : mask.data()) n += v > 0.5f;
  return n / static_cast<double>(mask.pixel_count());
}

struct Errors {
  image::ErrorMetrics whole, band;
  double revealed_rel_mse = std::numeric_limits<double>::quiet_NaN();
};
Errors errors(const image::Image& test, const image::Image& ref, const image::Image& band,
              const image::Image* revealed = nullptr) {
  Errors e{image::compare(test, ref), image::compare(test, ref, &band)};
  if (revealed && fraction_set(*revealed) > 0)
    e.revealed_rel_mse = image::compare(test, ref, revealed).rel_mse;
  return e;
}

// The pixels where some revealed layer is set: where the pinhole image hides what the lens sees.
image::Image revealed_region(const preview::PreviewInputs& in) {
  image::Image m(in.color.width(), in.color.height(), 1, 0.0f);
  for (const preview::RevealedLayer& r : in.revealed)
    for (size_t p = 0; p < m.pixel_count(); ++p)
      if (r.mask.data()[p] > 0.5f) m.data()[p] = 1.0f;
  return m;
}

// The lens integral of every band pixel evaluated through the inputs themselves: `rays` lens rays
// (a stratified grid, concentric-mapped and rotated per pixel) marched through the layered depth
// image of the pinhole surface and the revealed fragments. A ray through lens point u crosses the
// depth of signed CoC c at image position p + u c / 2 (eqs. (2.4)-(2.6) in pixels, the form of the
// mask's lens-reach rule); it takes the first surface, pinhole or revealed, that it meets within
// one CoC unit behind it, at pixel resolution. No layering, matting or blur: partial visibility
// is exact up to the inputs' pixels, so this measures what the inputs carry, not what a composite
// makes of them. Pixels outside the band, and the few rays that meet nothing, keep `fallback`.
image::Image exact_visibility(const preview::PreviewInputs& in, const image::Image& fallback,
                              const image::Image& band, const preview::PreviewOptions& options,
                              int rays) {
  const int w = in.color.width(), h = in.color.height();
  const preview::CocMap coc(in.imaging, options.max_coc_radius);
  // Per pixel: its surfaces (pinhole first, then revealed) sorted by CoC, in one array.
  struct Surface {
    float c;
    const float* rgb;
  };
  std::vector<size_t> first(static_cast<size_t>(w) * h + 1, 0);
  std::vector<Surface> surfaces;
  float c_lo = std::numeric_limits<float>::infinity(), c_hi = -c_lo;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t start = surfaces.size();
      surfaces.push_back({coc(in.depth.at(x, y, 0)), in.color.pixel(x, y)});
      for (const preview::RevealedLayer& r : in.revealed)
        if (r.mask.at(x, y, 0) > 0.5f)
          surfaces.push_back({coc(r.depth.at(x, y, 0)), r.color.pixel(x, y)});
      std::sort(surfaces.begin() + start, surfaces.end(),
                [](const Surface& a, const Surface& b) { return a.c < b.c; });
      for (size_t k = start; k < surfaces.size(); ++k) {
        c_lo = std::min(c_lo, surfaces[k].c);
        c_hi = std::max(c_hi, surfaces[k].c);
      }
      first[static_cast<size_t>(y) * w + x + 1] = surfaces.size();
    }
  const int grid = std::max(1, static_cast<int>(std::lround(std::sqrt(rays))));
  std::vector<glm::vec2> lens;
  for (int a = 0; a < grid; ++a)
    for (int b = 0; b < grid; ++b)
      lens.push_back(lens::concentric_disk({(a + 0.5f) / grid, (b + 0.5f) / grid}));
  constexpr float kThickness = 1.0f;  // CoC units behind a surface that still count as a hit
  image::Image out = fallback;
  tbb::parallel_for(0, h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      if (band.at(x, y, 0) < 0.5f) continue;
      // A fixed per-pixel rotation of the grid turns its structure into noise.
      const float angle = 2.3999632f * static_cast<float>((x * 7 + y * 13) % 97);
      const float cs = std::cos(angle), sn = std::sin(angle);
      double sum[3] = {0, 0, 0};
      for (const glm::vec2& l : lens) {
        const glm::vec2 u{cs * l.x - sn * l.y, sn * l.x + cs * l.y};
        const float len = glm::length(u);
        // Steps of half a pixel along the ray's image path; one step for the lens centre.
        const float dc = len > 1e-6f ? 1.0f / len : c_hi - c_lo + 2 * kThickness;
        const float* hit = nullptr;
        for (float c = c_lo - kThickness; c <= c_hi + dc && !hit; c += dc) {
          const float mid = c + 0.5f * dc;
          const int qx = static_cast<int>(std::floor(x + 0.5f + u.x * mid / 2));
          const int qy = static_cast<int>(std::floor(y + 0.5f + u.y * mid / 2));
          if (qx < 0 || qy < 0 || qx >= w || qy >= h) continue;
          const size_t q = static_cast<size_t>(qy) * w + qx;
          for (size_t k = first[q]; k < first[q + 1]; ++k)
            if (surfaces[k].c <= c + dc && surfaces[k].c >= c - kThickness) {
              hit = surfaces[k].rgb;
              break;
            }
        }
        if (!hit) hit = fallback.pixel(x, y);
        for (int ch = 0; ch < 3; ++ch) sum[ch] += hit[ch];
      }
      for (int ch = 0; ch < 3; ++ch) out.at(x, y, ch) = static_cast<float>(sum[ch] / lens.size());
    }
  });
  return out;
}

// Fastest of each stage over repeated runs.
struct StageMin {
  double pinhole = 1e300, mask = 1e300, id = 1e300, build = 1e300, extra = 1e300, post = 1e300;
  void add(const preview::ScenePreviewTimings& t) {
    pinhole = std::min(pinhole, t.pinhole_render_ms);
    mask = std::min(mask, t.mask_ms());
    id = std::min(id, t.id_render_ms);
    build = std::min(build, t.mask_build_ms);
    extra = std::min(extra, t.extra_render_ms);
    post = std::min(post, t.postprocess_ms);
  }
};

// Tiles of equal size into one image: `cols` per row, row-major.
image::Image mosaic(const std::vector<image::Image>& tiles, int cols) {
  const int w = tiles[0].width(), h = tiles[0].height();
  const int rows = static_cast<int>((tiles.size() + cols - 1) / cols);
  image::Image out(cols * w, rows * h, 3, 0.0f);
  for (size_t i = 0; i < tiles.size(); ++i) {
    const int ox = static_cast<int>(i % cols) * w, oy = static_cast<int>(i / cols) * h;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) std::copy_n(tiles[i].pixel(x, y), 3, out.pixel(ox + x, oy + y));
  }
  return out;
}

// The reference, darkened outside the edge band.
image::Image band_view(const image::Image& ref, const image::Image& band) {
  image::Image out = ref;
  for (int y = 0; y < ref.height(); ++y)
    for (int x = 0; x < ref.width(); ++x)
      if (band.at(x, y, 0) < 0.5f)
        for (int k = 0; k < 3; ++k) out.at(x, y, k) *= 0.15f;
  return out;
}

int run(const Options& o) {
  preview::PreviewOptions options;  // the defaults, as the CLI uses them (all threads)
  if (o.direct_blur_radius >= 0) options.direct_blur_radius = o.direct_blur_radius;

  bench::Table t31({"scene", "size", "pinhole spp", "layers", "revealed layers", "revealed px [%]",
                    "pinhole render [ms]", "extra-region mask [ms]", "(id renders [ms])",
                    "(mask build [ms])", "extra render [ms]", "post-process Kraus [ms]",
                    "post-process ours [ms]", "total Kraus [ms]", "total ours [ms]"});
  bench::Table terr({"scene", "method", "relMSE", "SSIM", "edge relMSE", "edge SSIM",
                     "edge band [%]", "revealed relMSE", "post-process [ms]"});
  bench::Table t43(
      {"scene", "method", "spp", "time [s]", "relMSE", "SSIM", "edge relMSE", "edge SSIM"});
  // The occlusion fix against Kraus & Strengert, both with the default "over" composite (the
  // paper's comparison); then the fix without its edge trace, the ratio with both on slabs, and the
  // fix (over) against Kraus & Strengert on slabs.
  bench::Table ttarget({"scene", "edge relMSE Kraus", "edge relMSE ours", "ratio ours/Kraus",
                        "target <= 0.5 met", "ratio layers only/Kraus", "ratio, both slabs",
                        "ratio vs Kraus slabs", "ratio exact visibility/Kraus",
                        "revealed relMSE Kraus", "revealed relMSE ours"});
  nlohmann::json scene_info = nlohmann::json::array();

  for (const std::string& file : o.scenes) {
    if (o.refocus_only) break;
    SceneSetup s = load(file, o.width, o);
    const image::Image ref = reference(s, o);
    std::fprintf(stderr, "measuring %s\n", s.name.c_str());
    render::RenderSettings ps = s.base;
    ps.spp = o.spp;

    // 1. Table 3.1: both layered variants, alternating, fastest of each stage.
    StageMin kraus, ours;
    preview::ScenePreview fixed;  // the last occlusion-fix run: its inputs feed the error table
    for (int r = 0; r < o.repeats; ++r) {
      kraus.add(preview::render_scene_preview(s.scene, *s.accel, s.camera(), ps,
                                              PreviewMethod::Layered, options)
                    .timings);
      fixed = preview::render_scene_preview(s.scene, *s.accel, s.camera(), ps,
                                            PreviewMethod::LayeredOcclusion, options);
      ours.add(fixed.timings);
    }
    const preview::ScenePreviewTimings& ft = fixed.timings;
    // Both variants render the same pinhole image: its fastest time serves both, and the totals
    // are sums of the fastest stages (as the paper's totals are sums of its columns).
    const double pinhole_ms = std::min(kraus.pinhole, ours.pinhole);
    const double kraus_total = pinhole_ms + kraus.post;
    const double ours_total = pinhole_ms + ours.mask + ours.extra + ours.post;
    const double revealed_pct =
        100.0 * ft.revealed_pixels / static_cast<double>(ps.width * ps.height);
    t31.add_row({s.name, std::to_string(ps.width) + "x" + std::to_string(ps.height), o.spp,
                 ft.layers, ft.revealed_layers, Cell(revealed_pct, 1), Cell(pinhole_ms, 0),
                 Cell(ours.mask, 1), Cell(ours.id, 1), Cell(ours.build, 2), Cell(ours.extra, 0),
                 Cell(kraus.post, 2), Cell(ours.post, 2), Cell(kraus_total, 0),
                 Cell(ours_total, 0)});

    // 2. Errors of every post-process on the same inputs (the same pinhole noise).
    const preview::PreviewInputs& in = fixed.inputs;
    const image::Image band = edge_band(in.depth, in.imaging, options);
    const image::Image revealed = revealed_region(in);
    std::map<std::string, image::Image> images;
    std::map<std::string, Errors> errs;
    const double band_pct = 100 * fraction_set(band);
    // One row of the error table; the image and its errors are kept under `label`.
    auto record = [&](const std::string& label, const image::Image& img, double ms) {
      Errors e = errors(img, ref, band, &revealed);
      terr.add_row({s.name, label, Cell(e.whole.rel_mse, 5), Cell(e.whole.ssim, 4),
                    Cell(e.band.rel_mse, 5), Cell(e.band.ssim, 4), Cell(band_pct, 1),
                    Cell(e.revealed_rel_mse, 5), Cell(ms, 2)});
      images[label] = img;
      errs[label] = e;
    };
    auto post = [&](const std::string& label, PreviewMethod m,
                    const preview::PreviewInputs* inputs = nullptr,
                    const preview::PreviewOptions* opts = nullptr) {
      double best = 1e300;
      image::Image img;
      preview::PreviewWorkspace ws;
      for (int r = 0; r < o.repeats; ++r) {
        auto t0 = clock_type::now();
        img = preview::render_preview(inputs ? *inputs : in, m, opts ? *opts : options, ws);
        best = std::min(best, ms_since(t0));
      }
      record(label, img, best);
    };
    record("pinhole (no blur)", in.color, 0.0);
    post("gather", PreviewMethod::Gather);
    post("scatter", PreviewMethod::Scatter);
    post("Kraus (layered)", PreviewMethod::Layered);
    post("occlusion fix", PreviewMethod::LayeredOcclusion);
    {
      // The fix without its edge trace: layers everywhere (PreviewOptions::edge_rays).
      preview::PreviewOptions layers_only = options;
      layers_only.edge_rays = 0;
      post("occlusion fix, layers only", PreviewMethod::LayeredOcclusion, nullptr, &layers_only);
    }
    {
      // Both methods with the slab composite (options.h, LayerComposite).
      preview::PreviewOptions slabs = options;
      slabs.layer_composite = preview::LayerComposite::Slabs;
      post("Kraus, slab composite", PreviewMethod::Layered, nullptr, &slabs);
      post("occlusion fix, slab composite", PreviewMethod::LayeredOcclusion, nullptr, &slabs);
    }
    {
      // The same with masks that keep every clipped pixel (no lens-reach test): more revealed
      // surface, so an upper bound of what the revealed layers can contribute.
      preview::PreviewOptions all = options;
      all.mask_lens_reach = false;
      preview::ScenePreview wide = preview::render_scene_preview(
          s.scene, *s.accel, s.camera(), ps, PreviewMethod::LayeredOcclusion, all);
      post("occlusion fix, no lens reach", PreviewMethod::LayeredOcclusion, &wide.inputs, &all);
    }
    // What the inputs carry: the band's lens integral traced through them (exact_visibility).
    const std::string exact_label = "exact visibility, " + std::to_string(o.exact_rays) + " rays";
    {
      auto t0 = clock_type::now();
      image::Image img = exact_visibility(in, images["occlusion fix"], band, options, o.exact_rays);
      record(exact_label, img, ms_since(t0));
    }
    // The paper's comparison (both on Kraus & Strengert's "over" composite, the default), then the
    // same with slabs, and the fix against Kraus & Strengert on slabs.
    const Errors& k_over = errs["Kraus (layered)"];
    const Errors& fix = errs["occlusion fix"];
    const Errors& kraus_slabs = errs["Kraus, slab composite"];
    const double ratio = fix.band.rel_mse / k_over.band.rel_mse;
    const double ratio_slabs =
        errs["occlusion fix, slab composite"].band.rel_mse / kraus_slabs.band.rel_mse;
    const double ratio_mixed = fix.band.rel_mse / kraus_slabs.band.rel_mse;
    const double ratio_layers_only =
        errs["occlusion fix, layers only"].band.rel_mse / k_over.band.rel_mse;
    if (s.name != "cornell_box")
      ttarget.add_row({s.name, Cell(k_over.band.rel_mse, 5), Cell(fix.band.rel_mse, 5),
                       Cell(ratio, 2), ratio <= 0.5, Cell(ratio_layers_only, 2),
                       Cell(ratio_slabs, 2), Cell(ratio_mixed, 2),
                       Cell(errs[exact_label].band.rel_mse / k_over.band.rel_mse, 2),
                       Cell(k_over.revealed_rel_mse, 5), Cell(fix.revealed_rel_mse, 5)});

    // 3. Table 4.3: DRT, cached DRT, and the two previews (whole pipeline).
    auto drt = [&](const std::string& label, const std::string& backend) {
      double best = 1e300;
      image::Image img;
      for (int r = 0; r < std::min(o.repeats, 2); ++r) {
        render::RenderSettings d = s.base;
        d.spp = o.drt_spp;
        std::unique_ptr<cache::RadianceCache> c = cache::make_radiance_cache(backend);
        d.cache.cache = c.get();
        auto t0 = clock_type::now();
        img = render::render(s.scene, *s.accel, s.camera(), d).color;
        best = std::min(best, ms_since(t0));
      }
      Errors e = errors(img, ref, band);
      t43.add_row({s.name, label, o.drt_spp, Cell(best * 1e-3, 3), Cell(e.whole.rel_mse, 5),
                   Cell(e.whole.ssim, 4), Cell(e.band.rel_mse, 5), Cell(e.band.ssim, 4)});
    };
    drt("DRT", "none");
    drt("DRT + cache (vdb)", "vdb");
    for (auto [label, total] :
         {std::pair{"Kraus (layered)", kraus_total}, std::pair{"occlusion fix", ours_total}}) {
      const Errors& e = errs[label];
      t43.add_row({s.name, std::string(label) + " preview", o.spp, Cell(total * 1e-3, 3),
                   Cell(e.whole.rel_mse, 5), Cell(e.whole.ssim, 4), Cell(e.band.rel_mse, 5),
                   Cell(e.band.ssim, 4)});
    }
    scene_info.push_back({{"scene", s.name},
                          {"lens",
                           {{"focal_length", s.base.lens.focal_length},
                            {"fstop", s.base.lens.fstop},
                            {"focus_distance", s.base.lens.focus_distance}}},
                          {"layers", fixed.timings.layers},
                          {"edge_band_fraction", fraction_set(band)},
                          {"coverage",
                           {{"near_depth", fixed.coverage.near_depth},
                            {"far_depth", std::isfinite(fixed.coverage.far_depth)
                                              ? nlohmann::json(fixed.coverage.far_depth)
                                              : nlohmann::json("inf")}}}});

    if (!o.figures.empty()) {
      const double max_err = 0.25;
      const image::Image& k = images["Kraus (layered)"];
      const image::Image& f = images["occlusion fix"];
      image::Image fig = mosaic(
          {k, f, ref, image::false_color(image::relative_error_map(k, ref), max_err),
           image::false_color(image::relative_error_map(f, ref), max_err), band_view(ref, band)},
          3);
      fs::create_directories(o.figures);
      const std::string suffix = o.width != 160 ? "_" + std::to_string(o.width) : "";
      std::string path =
          (fs::path(o.figures) / ("preview_" + s.name + suffix + ".png")).string();
      image::write_image(path, fig);
      std::fprintf(stderr, "wrote %s\n", path.c_str());
    }
  }

  // 4. Refocus at 640x480 on colour bars: render and save inputs (cheap shading: only the
  // post-process is timed), then load + post-process as `dofcache refocus` does (fresh workspace),
  // with the saved lens and with another one; and the post-process alone on 2 threads, on every
  // shipped scene.
  bench::Table tref({"what", "size", "threads", "load [ms]", "post-process [ms]", "total [ms]",
                     "target [ms]", "met"});
  if (!o.skip_refocus) {
    auto cheap_preview = [&](const SceneSetup& s) {
      render::RenderSettings r = s.base;
      r.spp = 1;
      r.shading.gather_rays = 4;
      r.shading.light_samples = 1;
      return preview::render_scene_preview(s.scene, *s.accel, s.camera(), r,
                                           PreviewMethod::LayeredOcclusion, options);
    };
    SceneSetup s = load("color_bars.gltf", o.refocus_width, o);
    const render::RenderSettings& r = s.base;
    preview::ScenePreview p = cheap_preview(s);
    const std::string size = std::to_string(r.width) + "x" + std::to_string(r.height);
    fs::path file = fs::temp_directory_path() / "dofcache_preview_table_bench_inputs.exr";
    preview::save_preview_inputs(file.string(), p.inputs, p.coverage, options);
    const std::uintmax_t file_bytes = fs::file_size(file);

    for (auto [label, lens] :
         {std::pair{"refocus, saved lens", p.inputs.imaging.lens},
          std::pair{"refocus, f/2.8 at 1.6 m", lens::ThinLens{0.1, 2.8, 1.6}}}) {
      double best_load = 1e300, best_post = 1e300, best_total = 1e300;
      for (int k = 0; k < o.refocus_repeats; ++k) {
        auto t0 = clock_type::now();
        preview::SavedPreviewInputs saved = preview::load_preview_inputs(file.string());
        const double load_ms = ms_since(t0);
        auto t1 = clock_type::now();
        preview::RefocusedInputs ri =
            preview::refocus_inputs(std::move(saved.inputs), saved.coverage, lens, saved.options);
        image::Image img =
            preview::render_preview(ri.inputs, PreviewMethod::LayeredOcclusion, saved.options);
        const double post_ms = ms_since(t1);
        best_load = std::min(best_load, load_ms);
        best_post = std::min(best_post, post_ms);
        best_total = std::min(best_total, load_ms + post_ms);
      }
      tref.add_row({label, size, "all", Cell(best_load, 1), Cell(best_post, 1), Cell(best_total, 1),
                    100, best_total < 100.0});
    }
    // The post-process alone on 2 threads, its workspace reused: the fastest of the runs.
    auto post_process_row = [&](const std::string& label, const preview::PreviewInputs& in,
                                PreviewMethod m) {
      preview::PreviewOptions two = options;
      two.threads = 2;
      preview::PreviewWorkspace ws;
      double best = 1e300;
      for (int k = 0; k < 4 * o.refocus_repeats; ++k) {
        auto t0 = clock_type::now();
        image::Image img = preview::render_preview(in, m, two, ws);
        best = std::min(best, ms_since(t0));
      }
      tref.add_row({label,
                    std::to_string(in.color.width()) + "x" + std::to_string(in.color.height()), 2,
                    Cell(0.0, 1), Cell(best, 1), Cell(best, 1), 20, best < 20.0});
    };
    auto post_process_rows = [&](const std::string& scene, const preview::PreviewInputs& in) {
      post_process_row("post-process, Kraus, " + scene, in, PreviewMethod::Layered);
      post_process_row("post-process, occlusion fix, " + scene, in,
                       PreviewMethod::LayeredOcclusion);
    };
    post_process_rows(s.name, p.inputs);
    for (const char* other : {"color_spheres.gltf", "cornell_box.gltf"}) {
      SceneSetup so = load(other, o.refocus_width, o);
      post_process_rows(so.name, cheap_preview(so).inputs);
    }
    // The same post-process on the synthetic demo scene of preview_postprocess_bench, in the same
    // conditions: docs/preview.md lists 10.7 ms (layered) and 12.1 ms (occlusion fix) for it on
    // two uncontended cores, so this row tells how much the machine was contended.
    {
      preview::SyntheticScene demo = preview::make_demo_scene(r.width, r.height);
      post_process_rows("synthetic demo scene", demo.pinhole_with_revealed_layers(options));
    }
    fs::remove(file);
    std::printf("\nsaved inputs at %s: %.2f MB (%d revealed layers, %llu revealed px)\n",
                size.c_str(), file_bytes / 1e6, p.timings.revealed_layers,
                static_cast<unsigned long long>(p.timings.revealed_pixels));
  }

  std::printf("\nTable 3.1 again: fastest of %d runs per stage, %d pinhole samples per pixel\n",
              o.repeats, o.spp);
  t31.print();
  std::printf("\nError against a %d-spp DRT reference (whole image and edge band)\n", o.ref_spp);
  terr.print();
  std::printf("\nTable 4.3 again: time and error\n");
  t43.print();
  std::printf("\nTarget: occlusion fix with at most half of Kraus & Strengert's edge-band error\n");
  ttarget.print();
  std::printf("\nRefocus and post-process at %dx%d (fastest of the runs)\n", o.refocus_width,
              o.refocus_width * 3 / 4);
  tref.print();

  nlohmann::json results;
  results["settings"] = {{"width", o.width},
                         {"spp", o.spp},
                         {"drt_spp", o.drt_spp},
                         {"reference_spp", o.ref_spp},
                         {"threads", o.threads},
                         {"repeats", o.repeats},
                         {"exact_visibility_rays", o.exact_rays},
                         {"edge_rays", options.edge_rays},
                         {"refocus_width", o.refocus_width},
                         {"direct_blur_radius", options.direct_blur_radius},
                         {"edge_band",
                          "pixels within max(R_p, R_q) (>= 1 px) of 4-neighbours "
                          "whose signed CoC diameters differ by more than 1 px"}};
  results["scenes"] = scene_info;
  results["columns"] = t31.header();
  results["rows"] = t31.to_json();
  results["errors"] = terr.to_json();
  results["table_4_3"] = t43.to_json();
  results["edge_target"] = ttarget.to_json();
  results["refocus"] = tref.to_json();
  std::printf("\nwrote %s\n", bench::write_results(o.results, results).c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{"The preview on the shipped scenes: the paper's Tables 3.1 and 4.3 again, the error "
               "of every post-process against a converged reference, and refocus timings.",
               "preview_table_bench"};
  bench::add_common_options(app, o.width, o.threads, o.results);
  bench::add_count_option(app, "--spp", o.spp, "Pinhole samples per pixel of the previews");
  bench::add_count_option(app, "--drt-spp", o.drt_spp,
                          "Lens samples per pixel of the DRT rows of Table 4.3");
  bench::add_count_option(app, "--ref-spp", o.ref_spp,
                          "Lens samples per pixel of the converged uncached reference");
  bench::add_count_option(app, "--repeats", o.repeats,
                          "Runs of every stage; the fastest is kept");
  bench::add_count_option(app, "--exact-rays", o.exact_rays,
                          "Lens rays per edge-band pixel of the exact-visibility row (the lens "
                          "integral traced through the preview's own inputs)");
  app.add_option("--refocus-width", o.refocus_width,
                 "Image width of the refocus timings (section 4; the height is 3/4 of it)")
      ->check(bench::in_range(1, 16384));
  bench::add_scene_option(app, o.scenes);
  app.add_option("--figures", o.figures,
                 "Also write one comparison image per scene as DIR/preview_<scene>.png")
      ->type_name("DIR");
  app.add_option("--refocus-only", o.refocus_only, "1: only the refocus timings (section 4)")
      ->check(bench::in_range(0, 1));
  app.add_option("--skip-refocus", o.skip_refocus, "1: skip the refocus timings (section 4)")
      ->check(bench::in_range(0, 1));
  app.add_option("--direct-blur-radius", o.direct_blur_radius,
                 "Override PreviewOptions::direct_blur_radius (pixels; 0: always the pyramid); "
                 "negative: keep the preview's default")
      ->check(bench::in_range(-1.0, 1e3));
  bench::parse_command_line(app, argc, argv);
  return bench::run_guarded(app, [&] { return run(o); });
}
