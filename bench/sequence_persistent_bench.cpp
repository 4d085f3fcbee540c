// Camera-path sequences with a persistent radiance cache on the shipped paths: the slow dolly (a
// glTF animation, sampled at 12 fps: 25 frames of small camera motion), the focus pull (a keyframe
// file, 36 frames) and the gallery walk (48 frames, 4.8 m of camera motion with a rack focus).
// For each path, three ways of rendering every frame run side by side, interleaved frame by frame
// so that a change in machine load hits all alike:
//   none        DRT without a cache;
//   fresh       the vdb cache, emptied before every frame;
//   persistent  the vdb cache carried across frames (reuse rule, eviction: persistent_cache.h).
// Per frame: time (wall and process CPU), rays, shading points, relative MSE against a converged
// reference (uncached DRT, --ref-spp lens samples, cached in bench/results/references/), the
// reuse rate (lookups served entirely by samples of earlier frames) and flicker (mean absolute
// difference to the previous frame; the reference's own figure is what the scene's change
// explains, the rest is error). Writes bench/results/sequence_persistent.{json,csv}.
//   sequence_persistent_bench [--width W] [--spp N] [--ref-spp N] [--ref-every K]
//                             [--fresh-every K] [--fps F] [--threads T] [--frames N]
//                             [--path dolly|focus_pull|walk]... [--results NAME]   (--help for more)
// Long or large paths: --ref-every K keeps references (and uncached renders) to a pair of frames
// every K, --fresh-every K renders the fresh cache on a subset, --ref-spp 0 drops the references.
#include <sys/resource.h>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "bench_common.h"
#include "dofcache/core/rng.h"
#include "dofcache/image/image_io.h"
#include "dofcache/image/metrics.h"
#include "dofcache/render/renderer.h"
#include "dofcache/render/setup.h"
#include "dofcache/scene/accel.h"
#include "dofcache/sequence/camera_path.h"
#include "dofcache/cache/persistent_cache.h"
#include "dofcache/core/stopwatch.h"
#include "dofcache/sequence/sequence_renderer.h"

using namespace dofcache;
namespace fs = std::filesystem;

namespace {

struct Options {
  int width = 96, spp = 16, ref_spp = 256, threads = 0, max_frames = 0, ref_every = 1,
      fresh_every = 1;
  double fps = 0.0;  // 0: each path's own
  std::vector<std::string> paths;  // names of kCases to run
  std::string results = "sequence_persistent";
};

struct PathCase {
  std::string name, scene_file, keyframe_file;  // keyframe_file empty: the glTF animation
  double fps;
};

const PathCase kCases[] = {
    {"dolly", "cornell_box_dolly.gltf", "", 12.0},
    {"focus_pull", "cornell_box.gltf", "paths/cornell_focus_pull.json", 24.0},
    {"walk", "gallery.glb", "paths/gallery_walk.json", 24.0},
};

enum Method { kNone, kFresh, kPersistent, kMethods };
const char* kMethodNames[] = {"none", "fresh", "persistent"};

double cpu_seconds() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

struct FrameResult {
  bool rendered = false;
  double wall = 0, cpu = 0, rel_mse = 0, flicker = -1, error_flicker = -1;
  std::uint64_t rays = 0, shading_points = 0;
  cache::FrameCacheStats cache;
};

// Mean absolute difference over pixels and channels.
double mean_abs_diff(const image::Image& a, const image::Image& b) {
  double sum = 0.0;
  for (std::size_t i = 0; i < a.data().size(); ++i) sum += std::abs(a.data()[i] - b.data()[i]);
  return sum / static_cast<double>(a.data().size());
}

// Mean absolute change of the error between consecutive frames: |(a1 - r1) - (a0 - r0)|.
double error_change(const image::Image& a1, const image::Image& r1, const image::Image& a0,
                    const image::Image& r0) {
  double sum = 0.0;
  for (std::size_t i = 0; i < a1.data().size(); ++i)
    sum += std::abs((a1.data()[i] - r1.data()[i]) - (a0.data()[i] - r0.data()[i]));
  return sum / static_cast<double>(a1.data().size());
}

std::string hex(std::uint64_t v) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
  return buf;
}

// The converged reference of one frame: uncached DRT with many lens samples, its own seeds,
// rendered as two independent halves. Their difference measures the reference's own noise, which
// adds to every error measured against it: relMSE(a, b) / 4 estimates that term (the mean's
// variance is a quarter of the halves' squared difference), and it is subtracted so that an error
// near the reference's noise is not read as a floor.
struct Reference {
  image::Image color;
  double noise_rel_mse = 0.0;
};

Reference reference(const scene::Scene& scene, const scene::Accel& accel,
                    const sequence::FrameSpec& f, const render::RenderSettings& base,
                    const Options& o, const std::string& name) {
  std::uint64_t key = hash_combine(scene.content_hash, static_cast<std::uint64_t>(o.ref_spp));
  for (int c = 0; c < 4; ++c)
    for (int k = 0; k < 4; ++k) {
      float v = f.camera.camera_to_world[c][k];
      std::uint32_t bits;
      std::memcpy(&bits, &v, 4);
      key = hash_combine(key, bits);
    }
  for (double v : {f.lens.focal_length, f.lens.fstop, f.lens.focus_distance}) {
    std::uint64_t bits;
    std::memcpy(&bits, &v, 8);
    key = hash_combine(key, bits);
  }
  key = hash_combine(key, static_cast<std::uint64_t>(base.shading.light_samples) << 32 |
                              static_cast<std::uint64_t>(base.shading.gather_rays));
  const std::string file_key = "sequence_" + name + "_" + std::to_string(base.width) + "x" +
                               std::to_string(base.height) + "_f" + std::to_string(f.number) +
                               "_" + hex(key).substr(0, 8);
  image::Image halves[2];
  for (int h = 0; h < 2; ++h)
    halves[h] = bench::cached_reference(file_key + "_half" + std::to_string(h), [&] {
      render::RenderSettings r = base;
      r.spp = std::max(1, o.ref_spp / 2);
      r.lens = f.lens;
      // Independent of the measured renders and of each other.
      r.seed = sequence::frame_seed(1000003 + 7919 * h, f.number);
      r.cache.cache = nullptr;
      return render::render(scene, accel, f.camera, r).color;
    });
  Reference ref;
  ref.noise_rel_mse = image::compare(halves[0], halves[1]).rel_mse / 4.0;
  ref.color = std::move(halves[0]);
  for (std::size_t i = 0; i < ref.color.data().size(); ++i)
    ref.color.data()[i] = 0.5f * (ref.color.data()[i] + halves[1].data()[i]);
  return ref;
}

// Frames with a reference (and a render without a cache, as costly): pairs of consecutive frames,
// one pair every `every` frames, so that the error flicker between two frames is still measured.
// --ref-spp 0: none (time and memory only).
bool has_reference(std::size_t i, const Options& o) {
  if (o.ref_spp <= 0) return false;
  return o.ref_every <= 1 || static_cast<int>(i % static_cast<std::size_t>(o.ref_every)) < 2;
}

// Frames rendered with a fresh cache: every --fresh-every'th frame, and every frame with a
// reference (a fresh frame depends on no other, so a subset measures its cost).
bool renders_fresh(std::size_t i, const Options& o) {
  return has_reference(i, o) || i % static_cast<std::size_t>(std::max(o.fresh_every, 1)) == 0;
}

double peak_rss_bytes() {
  rusage u;
  getrusage(RUSAGE_SELF, &u);
  return 1024.0 * static_cast<double>(u.ru_maxrss);  // kilobytes on Linux
}

int run(const Options& o) {
  bench::Table summary({"path", "frames", "method", "frames measured", "wall / frame [s]",
                        "CPU / frame [s]", "speed-up vs fresh (CPU)", "rays / frame [M]",
                        "shading points / frame", "mean relMSE", "relMSE / fresh (mean)",
                        "relMSE / fresh (max)", "mean reuse", "flicker", "reference flicker",
                        "error flicker"},
                       4);
  nlohmann::json per_frame_json = nlohmann::json::object();
  // The process's peak resident set after each path (it only grows: run one path to read its own).
  nlohmann::json peak_rss_json = nlohmann::json::object();
  cache::ReusePolicy policy;  // the defaults a user gets

  for (const PathCase& pc : kCases) {
    if (std::find(o.paths.begin(), o.paths.end(), pc.name) == o.paths.end()) continue;
    scene::Scene scene = render::load_scene(bench::scene_path(pc.scene_file));
    scene::Accel accel(scene);
    const scene::Camera& cam = scene.cameras[0];
    sequence::CameraPath path =
        pc.keyframe_file.empty()
            ? sequence::load_gltf_camera_path(bench::scene_path(pc.scene_file), cam)
            : sequence::load_keyframe_path(bench::scene_path(pc.keyframe_file), cam);
    const double fps = o.fps > 0.0 ? o.fps : pc.fps;
    auto [first, last] = sequence::path_frame_range(path, fps);
    if (o.max_frames > 0) last = std::min(last, first + o.max_frames - 1);
    std::vector<sequence::FrameSpec> frames =
        sequence::plan_frames(scene, accel, cam, path, fps, first, last, {});

    const render::RenderSettings base =
        bench::camera_settings(scene, accel, cam, o.width, o.spp, o.threads);
    std::fprintf(stderr, "%s: %zu frames at %dx%d, %d spp\n", pc.name.c_str(), frames.size(),
                 base.width, base.height, base.spp);

    std::vector<Reference> refs(frames.size());
    for (std::size_t i = 0; i < frames.size(); ++i)
      if (has_reference(i, o))
        refs[i] = reference(scene, accel, frames[i], base, o, pc.name);

    cache::PersistentCache fresh("vdb", policy, base.cache.radius),
        persistent("vdb", policy, base.cache.radius);
    std::vector<std::vector<FrameResult>> results(kMethods,
                                                  std::vector<FrameResult>(frames.size()));
    std::vector<image::Image> previous(kMethods);
    for (std::size_t i = 0; i < frames.size(); ++i) {
      const sequence::FrameSpec& f = frames[i];
      const bool measured = has_reference(i, o);
      std::fprintf(stderr, "  frame %d\r", f.number);
      for (int m = 0; m < kMethods; ++m) {
        if ((m == kNone && !measured) || (m == kFresh && !renders_fresh(i, o))) continue;
        render::RenderSettings r = base;
        r.lens = f.lens;
        r.seed = sequence::frame_seed(1, f.number);
        r.cache.frame = static_cast<std::uint32_t>(f.number);
        cache::PersistentCache* pcache =
            m == kFresh ? &fresh : m == kPersistent ? &persistent : nullptr;
        auto t0 = std::chrono::steady_clock::now();
        double c0 = cpu_seconds();
        if (m == kFresh) fresh.clear();
        if (pcache) r.cache.cache = pcache->begin_frame(f.number, render::make_camera(f.camera, r).frame_camera());
        render::RenderOutput out = render::render(scene, accel, f.camera, r);
        FrameResult& fr = results[m][i];
        if (pcache) fr.cache = pcache->end_frame();
        fr.cpu = cpu_seconds() - c0;
        fr.wall = seconds_since(t0);
        fr.rendered = true;
        fr.rays = out.stats.rays;
        fr.shading_points = out.stats.shading_points;
        if (measured)
          fr.rel_mse = image::compare(out.color, refs[i].color).rel_mse - refs[i].noise_rel_mse;
        if (i > 0 && results[m][i - 1].rendered) {  // flicker needs consecutive frames
          fr.flicker = mean_abs_diff(out.color, previous[m]);
          if (measured && has_reference(i - 1, o))
            fr.error_flicker =
                error_change(out.color, refs[i].color, previous[m], refs[i - 1].color);
        }
        previous[m] = std::move(out.color);
      }
    }

    // Per-path results: each method over the frames it rendered, its error ratios against the
    // fresh cache on the frames with a reference.
    nlohmann::json frames_json = nlohmann::json::array();
    for (std::size_t i = 0; i < frames.size(); ++i) {
      nlohmann::json row = {{"frame", frames[i].number},
                            {"focus_distance", frames[i].lens.focus_distance}};
      if (has_reference(i, o)) row["reference_noise_rel_mse"] = refs[i].noise_rel_mse;
      if (i > 0 && has_reference(i, o) && has_reference(i - 1, o))
        row["reference_flicker"] = mean_abs_diff(refs[i].color, refs[i - 1].color);
      for (int m = 0; m < kMethods; ++m) {
        const FrameResult& fr = results[m][i];
        if (!fr.rendered) continue;
        nlohmann::json j = {{"wall_seconds", fr.wall}, {"cpu_seconds", fr.cpu},
                            {"rays", fr.rays}, {"shading_points", fr.shading_points}};
        if (has_reference(i, o)) j["rel_mse"] = fr.rel_mse;
        if (fr.flicker >= 0) j["flicker"] = fr.flicker;
        if (fr.error_flicker >= 0) j["error_flicker"] = fr.error_flicker;
        if (m != kNone)
          j.update({{"reuse_rate", fr.cache.reuse_rate()}, {"hit_rate", fr.cache.hit_rate()},
                    {"inserted", fr.cache.inserted}, {"shrunk", fr.cache.shrunk},
                    {"evicted", fr.cache.evicted_unused + fr.cache.evicted_memory},
                    {"samples", fr.cache.samples_at_end},
                    {"memory_bytes", fr.cache.memory_bytes}});
        row[kMethodNames[m]] = j;
      }
      frames_json.push_back(row);
    }
    per_frame_json[pc.name] = frames_json;
    peak_rss_json[pc.name] = peak_rss_bytes();

    std::printf("\n%s: per frame (relMSE x 1e3, the reference's noise subtracted; reuse = lookups "
                "served by earlier frames)\n",
                pc.name.c_str());
    bench::Table detail({"frame", "focus [m]", "none", "fresh", "persistent", "pers./fresh",
                         "reuse", "fresh CPU [s]", "pers. CPU [s]", "new samples"},
                        3);
    for (std::size_t i = 0; i < frames.size(); ++i) {
      const FrameResult &nr = results[kNone][i], &fr = results[kFresh][i],
                        &pr = results[kPersistent][i];
      const bool measured = has_reference(i, o);
      auto err = [&](const FrameResult& x) {
        return measured ? bench::Table::Cell(1e3 * x.rel_mse, 3) : bench::Table::Cell("-");
      };
      detail.add_row({frames[i].number, bench::Table::Cell(frames[i].lens.focus_distance, 3),
                      err(nr), err(fr), err(pr),
                      measured ? bench::Table::Cell(pr.rel_mse / fr.rel_mse, 3)
                               : bench::Table::Cell("-"),
                      bench::Table::Cell(pr.cache.reuse_rate(), 3),
                      fr.rendered ? bench::Table::Cell(fr.cpu, 2) : bench::Table::Cell("-"),
                      bench::Table::Cell(pr.cpu, 2), static_cast<long>(pr.cache.inserted)});
    }
    detail.print();

    // A fresh frame depends on no other, so the mean over the frames it rendered stands for all.
    double fresh_cpu_per_frame = 0.0;
    int fresh_frames = 0;
    for (const FrameResult& fr : results[kFresh])
      if (fr.rendered) fresh_cpu_per_frame += fr.cpu, ++fresh_frames;
    fresh_cpu_per_frame /= std::max(1, fresh_frames);
    double ref_flicker = 0.0;
    int ref_pairs = 0;
    for (std::size_t i = 1; i < frames.size(); ++i)
      if (has_reference(i, o) && has_reference(i - 1, o))
        ref_flicker += mean_abs_diff(refs[i].color, refs[i - 1].color), ++ref_pairs;
    ref_flicker /= std::max(1, ref_pairs);
    for (int m = 0; m < kMethods; ++m) {
      double wall = 0, cpu = 0, rays = 0, sp = 0, err = 0, ratio = 0,
             ratio_max = 0, reuse = 0, flicker = 0, err_flicker = 0;
      int n = 0, n_err = 0, n_reuse = 0, n_flicker = 0, n_err_flicker = 0;
      for (std::size_t i = 0; i < frames.size(); ++i) {
        const FrameResult& fr = results[m][i];
        if (!fr.rendered) continue;
        ++n;
        wall += fr.wall, cpu += fr.cpu, rays += fr.rays, sp += fr.shading_points;
        if (has_reference(i, o)) {
          err += fr.rel_mse;
          const double q = fr.rel_mse / results[kFresh][i].rel_mse;
          ratio += q;
          ratio_max = std::max(ratio_max, q);
          ++n_err;
        }
        if (i > 0) reuse += fr.cache.reuse_rate(), ++n_reuse;
        if (fr.flicker >= 0) flicker += fr.flicker, ++n_flicker;
        if (fr.error_flicker >= 0) err_flicker += fr.error_flicker, ++n_err_flicker;
      }
      if (n == 0) continue;  // --ref-spp 0: no uncached renders
      const double frames_n = n, errs = std::max(1, n_err);
      summary.add_row({pc.name, static_cast<long>(frames.size()), kMethodNames[m],
                       static_cast<long>(n), bench::Table::Cell(wall / frames_n, 3),
                       bench::Table::Cell(cpu / frames_n, 3),
                       bench::Table::Cell(fresh_cpu_per_frame / (cpu / frames_n), 2),
                       bench::Table::Cell(rays * 1e-6 / frames_n, 2),
                       static_cast<long>(sp / frames_n), bench::Table::Cell(err / errs, 6),
                       bench::Table::Cell(ratio / errs, 3), bench::Table::Cell(ratio_max, 3),
                       bench::Table::Cell(m == kNone ? 0.0 : reuse / std::max(1, n_reuse), 3),
                       bench::Table::Cell(flicker / std::max(1, n_flicker), 5),
                       bench::Table::Cell(ref_flicker, 5),
                       bench::Table::Cell(err_flicker / std::max(1, n_err_flicker), 5)});
    }
  }
  std::printf("\nSummary (per frame: the mean over the frames a method rendered; speed-up = a fresh-"
              "cache frame's mean CPU time / this method's; relMSE / fresh = "
              "per-frame error ratio against the fresh cache; flicker = mean |frame - previous "
              "frame|; error flicker = mean |change of the error between frames|)\n");
  summary.print();
  nlohmann::json results;
  results["settings"] = {{"width", o.width}, {"spp", o.spp}, {"reference_spp", o.ref_spp},
                         {"reference_every", o.ref_every}, {"fresh_every", o.fresh_every},
                         {"fps", o.fps}, {"backend", "vdb"},
                         {"evict_after", policy.evict_after},
                         {"min_factor", render::CacheSettings{}.radius.min_factor},
                         {"shading", "defaults"}};
  results["columns"] = summary.header();
  results["rows"] = summary.to_json();
  results["per_frame"] = per_frame_json;
  results["peak_rss_bytes"] = peak_rss_json;
  std::printf("wrote %s\n", bench::write_results(o.results, results).c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{"Camera-path sequences with a persistent radiance cache against a fresh cache and "
               "no cache, frame by frame.",
               "sequence_persistent_bench"};
  bench::add_common_options(app, o.width, o.threads, o.results);
  bench::add_count_option(app, "--spp", o.spp, "Lens samples per pixel of the measured frames");
  bench::add_count_option(app, "--ref-spp", o.ref_spp,
                          "Lens samples per pixel of each frame's converged uncached reference "
                          "(0: no references, no uncached renders: time and memory only)",
                          0);
  bench::add_count_option(app, "--ref-every", o.ref_every,
                          "References (and renders without a cache) for a pair of consecutive "
                          "frames every this many frames (1: every frame)");
  bench::add_count_option(app, "--fresh-every", o.fresh_every,
                          "Render with a fresh cache only every this many frames (and on frames "
                          "with a reference): a fresh frame depends on no other");
  app.add_option("--fps", o.fps, "Frames per second along each path")
      ->default_str("the path's own")
      ->check(CLI::Range(1e-3, 1e4));
  bench::add_count_option(app, "--frames", o.max_frames,
                          "Render at most this many frames of each path (0: all)", 0);
  std::vector<std::string> names;
  for (const PathCase& pc : kCases) names.push_back(pc.name);
  o.paths = names;  // all of them unless --path picks some
  app.add_option("--path", o.paths, "Camera path to run (repeat for several)")
      ->type_name(CLI::detail::join(names, "|"))
      ->check(CLI::IsMember(names).description(""));
  bench::parse_command_line(app, argc, argv);
  return bench::run_guarded(app, [&] { return run(o); });
}
