// The paper's Tables 4.1 and 4.2 on our machine, plus the honest headline figure:
//   1. none vs octree vs vdb at the same lens samples per pixel: time, speed-up, error against a
//      converged reference (uncached DRT with many samples, cached in bench/results/references/);
//   2. equal-quality speed-up: the time uncached DRT needs to reach the cached render's error
//      (uncached runs at doubling spp, interpolated in log-log), divided by the cached time;
//   3. the minFactor sweep 0.5, 1, 2, 4 on the Cornell box.
// The equal-quality table has the fixed --sample-quality variants, the same with the sample
// quality render::recommended_sample_quality(spp) ("auto"; scaled by 32 / --gather-rays, see
// auto_sample_quality), and the regime of --hi-spp lens
// samples per pixel (default 256; 0 skips it), where a cached lens ray's low cost counts more.
// All variants run side by side in one process. Writes bench/results/cache_render.{json,csv}.
// --gather-rays / --light-samples set the per-ray shading of every measured render (the cache's
// sample quality multiplies them); --uncached-gather-rays gives uncached DRT its own gather rays
// (e.g. a cheap shade with more lens samples). The reference always uses the default shading: its
// expected image does not depend on them. With non-default shading and no --results, the results
// name says so (cache_render_gather128, ...), so the default-shading results are not overwritten.
//   cache_render_bench [--width W] [--spp N] [--hi-spp N] [--ref-spp N] [--threads T]
//                      [--sample-quality Q|auto] [--accuracy A] [--max-radius-px R] [--scene NAME]...
//                      [--gather-rays G] [--light-samples L] [--uncached-gather-rays G]
//                      [--results NAME]   (--help for more)
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <glm/geometric.hpp>

#include "bench_common.h"
#include "dofcache/cache/radiance_cache.h"
#include "dofcache/image/image_io.h"
#include "dofcache/image/metrics.h"
#include "dofcache/render/renderer.h"
#include "dofcache/render/setup.h"
#include "dofcache/scene/accel.h"

using namespace dofcache;
namespace fs = std::filesystem;

namespace {

struct Options {
  int width = 128, spp = 16, hi_spp = 256, ref_spp = 512, threads = 0;
  int sample_quality = 4;  // 0: auto_sample_quality(spp) of each render
  double accuracy = 0.1, max_radius_px = 8.0;
  render::ShadingSettings shading;  // per-ray shading of the measured renders
  int uncached_gather_rays = 0;     // 0: shading.gather_rays
  std::vector<std::string> scenes = {"cornell_box.gltf", "color_bars.gltf", "color_spheres.gltf",
                                     "glossy_closeup.glb"};
  std::string results = "cache_render";
  std::string lens_file;  // a real lens (render --lens-file); empty: the scene's thin lens
  bool thin_equivalent = false;  // that lens's thin-lens equivalent instead of the traced lens
  int blades = 0;                 // the aperture's shape (lens/aperture.h): 0 round
  double anamorphic_ratio = 1.0;
};

struct Run {
  double seconds;
  image::ErrorMetrics error;
  render::RenderStats stats;
  int sample_quality = 0;
};

struct SceneSetup {
  std::string name;
  scene::Scene scene;
  std::unique_ptr<scene::Accel> accel;
  render::RenderSettings base;
};

const Options* g_options = nullptr;  // the bench's settings, for run()

// "_blades6", "_anamorphic2", both, or "" for the round aperture.
std::string shape_suffix(const Options& o) {
  std::string suffix;
  if (o.blades != 0) suffix += "_blades" + std::to_string(o.blades);
  if (o.anamorphic_ratio != 1.0) {
    std::string q = std::to_string(o.anamorphic_ratio);
    q.erase(q.find_last_not_of('0') + 1);
    if (q.back() == '.') q.pop_back();
    suffix += "_anamorphic" + q;
  }
  return suffix;
}

SceneSetup load(const std::string& file, const Options& o) {
  SceneSetup s;
  s.name = fs::path(file).stem().string();
  s.scene = render::load_scene(bench::scene_path(file));
  s.accel = std::make_unique<scene::Accel>(s.scene);
  const scene::Camera& cam = s.scene.cameras[0];
  s.base = bench::camera_settings(s.scene, *s.accel, cam, o.width, 16, o.threads, o.lens_file);
  if (o.thin_equivalent && s.base.real_lens) {
    // The same picture through the thin lens the cache's reuse rule sees: its field of view, at
    // the front principal plane (render::ThinLensCamera's real-lens constructor).
    const lens::MountedLens m = s.base.real_lens;
    scene::Camera& c = s.scene.cameras[0];
    c.yfov = static_cast<float>(m.yfov());
    const glm::vec3 forward = -glm::normalize(glm::vec3(c.camera_to_world[2]));
    c.camera_to_world[3] += glm::vec4(forward * static_cast<float>(m.principal_offset()), 0.0f);
    s.base.real_lens = {};
    s.name += "_thin_" + fs::path(m.source).stem().string();
  }
  // A shaped aperture: the cache's footprint follows it (docs/lens.md); its name keys the
  // reference too.
  s.base.lens.aperture.blades = o.blades;
  s.base.lens.aperture.anamorphic_ratio = o.anamorphic_ratio;
  s.name += shape_suffix(o);
  return s;
}

// Always with the default shading: the reference's expected image does not depend on it, and its
// cached file (named without it) is shared by every shading setting.
image::Image reference(const SceneSetup& s, const Options& o) {
  render::RenderSettings base = s.base;
  base.shading = render::ShadingSettings{};
  return bench::converged_reference(s.name, s.scene, *s.accel, s.scene.cameras[0], base, o.ref_spp);
}

// The sample quality "auto" picks for `spp` lens samples with this run's gather rays.
int auto_sample_quality(int spp, const Options& o) {
  return render::recommended_sample_quality(spp, o.shading.gather_rays);
}

// A cached render's variant: radius rule, sample quality (0: auto for the spp) and, for
// the adaptive rule, the radius cap in pixel footprints (0: --max-radius-px).
struct Variant {
  const char* name;
  cache::RadiusRule rule;
  int quality;
  double max_radius_px = 0.0;
};

Run run(const SceneSetup& s, const image::Image& ref, int spp, const std::string& backend,
        double min_factor = 0.5, cache::RadiusRule rule = cache::RadiusRule::Paper,
        int quality = -1, double max_radius_px = 0.0) {
  render::RenderSettings r = s.base;
  r.spp = spp;
  r.shading = g_options->shading;
  if (backend == "none" && g_options->uncached_gather_rays > 0)
    r.shading.gather_rays = g_options->uncached_gather_rays;
  auto cache = cache::make_radiance_cache(backend);
  r.cache.cache = cache.get();
  r.cache.radius.min_factor = min_factor;
  r.cache.radius.rule = rule;
  if (quality < 0) quality = g_options->sample_quality;
  r.cache.sample_quality = quality > 0 ? quality : render::kAutoSampleQuality;
  r.cache.radius.accuracy = g_options->accuracy;
  r.cache.radius.max_radius_pixels =
      max_radius_px > 0.0 ? max_radius_px : g_options->max_radius_px;
  render::RenderOutput out = render::render(s.scene, *s.accel, s.scene.cameras[0], r);
  return {out.stats.seconds, image::compare(out.color, ref), out.stats,
          render::effective_sample_quality(r)};
}

// Time uncached DRT needs to reach `target` relMSE: doubling spp until below it, then log-log
// interpolation between the last two points. Returns -1 if not reached within the budget.
// `uncached` memoises the uncached runs by spp, shared by every cached variant of a scene.
double equal_quality_time(const SceneSetup& s, const image::Image& ref, double target,
                          int max_spp, std::map<int, Run>* uncached,
                          std::vector<std::pair<int, Run>>* curve) {
  double prev_t = 0, prev_e = 0;
  for (int spp = 1; spp <= max_spp; spp *= 2) {
    auto it = uncached->find(spp);
    if (it == uncached->end()) it = uncached->emplace(spp, run(s, ref, spp, "none")).first;
    const Run& u = it->second;
    curve->emplace_back(spp, u);
    if (u.error.rel_mse <= target) {
      if (prev_t <= 0) return u.seconds;
      double a = std::log(prev_e), b = std::log(u.error.rel_mse), g = std::log(target);
      double f = (a - g) / (a - b);
      return std::exp(std::log(prev_t) + f * (std::log(u.seconds) - std::log(prev_t)));
    }
    prev_t = u.seconds, prev_e = u.error.rel_mse;
  }
  return -1.0;
}

// Throws dofcache::Error, before anything is measured, if a cache sample's shading (the per-ray
// shading times a sample quality the bench will use) is out of ShadingSettings' range.
void check_sample_shading(const Options& o) {
  std::vector<int> qualities;
  if (o.sample_quality > 0) qualities.push_back(o.sample_quality);
  qualities.push_back(auto_sample_quality(o.spp, o));
  if (o.hi_spp > 0) qualities.push_back(auto_sample_quality(o.hi_spp, o));
  for (int q : qualities) render::cache_sample_shading(o.shading, q).validate();
}

int run_bench(const Options& o) {
  g_options = &o;
  check_sample_shading(o);
  bench::Table t41({"scene", "cache", "spp", "time [s]", "speed-up", "relMSE", "PSNR [dB]",
                    "SSIM", "hit rate", "samples", "cache MB"});
  bench::Table teq({"scene", "cache", "spp", "sample quality", "cached time [s]", "cached relMSE",
                    "uncached time to match [s]", "equal-quality speed-up"});
  bench::Table t42({"scene", "min factor", "time [s]", "relMSE", "PSNR [dB]", "samples"});
  nlohmann::json curves = nlohmann::json::array();

  for (const std::string& file : o.scenes) {
    SceneSetup s = load(file, o);
    image::Image ref = reference(s, o);
    std::fprintf(stderr, "measuring %s\n", s.name.c_str());
    Run none = run(s, ref, o.spp, "none");
    std::map<int, Run> uncached{{o.spp, none}};
    auto equal_quality = [&](const std::string& label, int spp, const Run& r) {
      std::vector<std::pair<int, Run>> curve;
      double t_eq = equal_quality_time(s, ref, r.error.rel_mse, 4 * o.ref_spp, &uncached, &curve);
      teq.add_row({s.name, label, spp, r.sample_quality, bench::Table::Cell(r.seconds, 2),
                   bench::Table::Cell(r.error.rel_mse, 5),
                   t_eq > 0 ? bench::Table::Cell(t_eq, 2) : bench::Table::Cell("not reached"),
                   t_eq > 0 ? bench::Table::Cell(t_eq / r.seconds, 1) : bench::Table::Cell("-")});
      nlohmann::json c = nlohmann::json::array();
      for (auto& [n, u] : curve)
        c.push_back({{"spp", n}, {"seconds", u.seconds}, {"rel_mse", u.error.rel_mse}});
      curves.push_back({{"scene", s.name}, {"cache", label}, {"spp", spp}, {"uncached", c}});
    };
    for (const char* backend : {"none", "octree", "vdb", "vdb adaptive"}) {
      bool adaptive = !std::strcmp(backend, "vdb adaptive");
      Run r = !std::strcmp(backend, "none") ? none
              : adaptive ? run(s, ref, o.spp, "vdb", 0.5, cache::RadiusRule::Adaptive)
                         : run(s, ref, o.spp, backend);
      t41.add_row({s.name, backend, o.spp, bench::Table::Cell(r.seconds, 2),
                   bench::Table::Cell(none.seconds / r.seconds, 2),
                   bench::Table::Cell(r.error.rel_mse, 5), bench::Table::Cell(r.error.psnr, 2),
                   bench::Table::Cell(r.error.ssim, 4), bench::Table::Cell(r.stats.cache_hit_rate(), 3),
                   static_cast<long>(r.stats.cache_samples),
                   bench::Table::Cell(r.stats.cache_memory_bytes / 1e6, 2)});
      if (!std::strcmp(backend, "vdb") || adaptive) equal_quality(backend, o.spp, r);
    }
    // The same with the recommended sample quality, then the many-lens-samples regime.
    const cache::RadiusRule paper = cache::RadiusRule::Paper;
    const cache::RadiusRule wide = cache::RadiusRule::Adaptive;
    for (const Variant& v : {Variant{"vdb", paper, 0}, Variant{"vdb adaptive", wide, 0}})
      equal_quality(v.name, o.spp, run(s, ref, o.spp, "vdb", 0.5, v.rule, v.quality));
    if (o.hi_spp > 0) {
      for (const Variant& v : {Variant{"vdb", paper, 0}, Variant{"vdb adaptive", wide, 0},
                               Variant{"vdb adaptive, max 1 px", wide, 0, 1.0}})
        equal_quality(v.name, o.hi_spp,
                      run(s, ref, o.hi_spp, "vdb", 0.5, v.rule, v.quality, v.max_radius_px));
    }
    if (s.name == "cornell_box") {
      for (double mf : {0.5, 1.0, 2.0, 4.0}) {
        Run r = run(s, ref, o.spp, "vdb", mf);
        t42.add_row({s.name, bench::Table::Cell(mf, 1), bench::Table::Cell(r.seconds, 2),
                     bench::Table::Cell(r.error.rel_mse, 5), bench::Table::Cell(r.error.psnr, 2),
                     static_cast<long>(r.stats.cache_samples)});
      }
    }
  }
  const int uncached_gather =
      o.uncached_gather_rays > 0 ? o.uncached_gather_rays : o.shading.gather_rays;
  std::printf("\nShading: %d light samples, %d gather rays per shade (uncached DRT: %d gather "
              "rays); reference: the default shading\n",
              o.shading.light_samples, o.shading.gather_rays, uncached_gather);
  std::printf("\nTable 4.1 again: the same %d lens samples per pixel, error against a %d-spp "
              "uncached reference (%d px wide)\n", o.spp, o.ref_spp, o.width);
  t41.print();
  std::printf("\nEqual-quality speed-up: uncached DRT time to reach the cached render's relMSE\n");
  teq.print();
  std::printf("\nTable 4.2 again: minFactor sweep (vdb)\n");
  t42.print();

  nlohmann::json results;
  results["settings"] = {{"width", o.width}, {"spp", o.spp}, {"hi_spp", o.hi_spp},
                         {"reference_spp", o.ref_spp},
                         {"threads", o.threads}, {"sample_quality", o.sample_quality},
                         {"accuracy", o.accuracy}, {"max_radius_px", o.max_radius_px},
                         {"gather_rays", o.shading.gather_rays},
                         {"light_samples", o.shading.light_samples},
                         {"uncached_gather_rays", uncached_gather}};
  results["rows"] = t41.to_json();
  results["columns"] = t41.header();
  results["equal_quality"] = teq.to_json();
  results["min_factor_sweep"] = t42.to_json();
  results["uncached_curves"] = curves;
  std::printf("\nwrote %s\n", bench::write_results(o.results, results).c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{"Radiance cache against uncached DRT on the shipped scenes: the paper's Tables 4.1 "
               "and 4.2, and the equal-quality speed-up.",
               "cache_render_bench"};
  bench::add_common_options(app, o.width, o.threads, o.results);
  bench::add_count_option(app, "--spp", o.spp, "Lens samples per pixel of the measured renders");
  bench::add_count_option(app, "--hi-spp", o.hi_spp,
                          "Lens samples per pixel of the many-samples regime (0: skip it)", 0);
  bench::add_count_option(app, "--ref-spp", o.ref_spp,
                          "Lens samples per pixel of the converged uncached reference");
  // "auto" is stored as 0: auto_sample_quality(spp) of each render.
  app.add_option("--sample-quality", o.sample_quality,
                 "A cache sample uses this many times the light and gather samples of a per-ray "
                 "shade, 1..256; auto (or 0): chosen from each render's spp, "
                 "render::recommended_sample_quality(spp * 32 / gather rays)")
      ->type_name("Q|auto")
      ->transform(CLI::Transformer({{"auto", "0"}}).description(""))
      ->check(bench::in_range(0, 256).description(""));
  app.add_option("--accuracy", o.accuracy,
                 "Adaptive radius: fraction of the harmonic mean distance to nearby geometry")
      ->check(bench::in_range(1e-3, 10.0));
  app.add_option("--max-radius-px", o.max_radius_px,
                 "Adaptive radius: cap in pixel footprints (the 'max 1 px' rows use 1)")
      ->check(bench::in_range(0.0, 1e4));
  app.add_option("--gather-rays", o.shading.gather_rays,
                 "Final-gather rays per shade of every measured render (the reference keeps the "
                 "default)")
      ->check(bench::in_range(1, 4096));
  app.add_option("--light-samples", o.shading.light_samples,
                 "Shadow rays to area lights per shade of every measured render (the reference "
                 "keeps the default)")
      ->check(bench::in_range(1, 4096));
  app.add_option("--uncached-gather-rays", o.uncached_gather_rays,
                 "Final-gather rays per shade of the uncached renders only (0: --gather-rays)")
      ->check(bench::in_range(0, 4096));
  bench::add_scene_option(app, o.scenes);
  app.add_option("--lens-file", o.lens_file,
                 "Every render through this real lens (render --lens-file; its table's stop, "
                 "autofocus), the reference too");
  app.add_flag("--thin-equivalent", o.thin_equivalent,
               "With --lens-file: through its thin-lens equivalent instead (the same focal length, "
               "f-number, focus and field of view), for the cache's speed-up side by side");
  app.add_option("--aperture-blades", o.blades,
                 "Every render through an aperture of this many straight blades (3-16; 0 round)")
      ->check(CLI::IsMember({0, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16}));
  app.add_option("--anamorphic-ratio", o.anamorphic_ratio,
                 "Every render through an anamorphic aperture: the bokeh's height over its width")
      ->check(bench::in_range(0.01, 100.0));
  bench::parse_command_line(app, argc, argv);
  // Non-default shading and no --results: say so in the name rather than overwrite the results
  // of the default shading.
  const render::ShadingSettings defaults;
  if (app.get_option("--results")->count() == 0) {
    if (o.shading.gather_rays != defaults.gather_rays)
      o.results += "_gather" + std::to_string(o.shading.gather_rays);
    if (o.shading.light_samples != defaults.light_samples)
      o.results += "_light" + std::to_string(o.shading.light_samples);
    if (o.uncached_gather_rays > 0 && o.uncached_gather_rays != o.shading.gather_rays)
      o.results += "_uncachedgather" + std::to_string(o.uncached_gather_rays);
    if (!o.lens_file.empty())
      o.results += (o.thin_equivalent ? "_thin_" : "_") + fs::path(o.lens_file).stem().string();
    o.results += shape_suffix(o);
  }
  return bench::run_guarded(app, [&] { return run_bench(o); });
}
