// What a shaped aperture costs against the round one (lens issue: at most 10 % more): camera-ray
// generation alone, and a whole cached DRT render of scenes/bokeh_lights.gltf at equal spp. The
// shapes are measured in interleaved rounds, so a machine's drift falls on all of them; ray
// generation keeps each shape's fastest round (a shared machine only ever adds time to a loop
// this short), the renders their median. Prints a table and writes bench/results/aperture.{json,csv}.
//   aperture_bench [--width W] [--spp N] [--rays N] [--rounds N] [--threads T] [--results NAME]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <cstdio>
#include <string>
#include <vector>

#include "bench_common.h"
#include "dofcache/image/image_io.h"
#include "dofcache/render/camera.h"
#include "dofcache/render/renderer.h"
#include "dofcache/render/setup.h"
#include "dofcache/scene/accel.h"

using namespace dofcache;

namespace {

struct Options {
  int width = 320, spp = 16, threads = 0, rounds = 7;
  int rays = 4'000'000;
  std::string results = "aperture";
};

struct Shape {
  const char* name;
  lens::ApertureShape shape;
};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// A 64x64 aperture image (a six-pointed star, written to the temporary directory).
std::string star_image() {
  image::Image im(64, 64, 3, 0.0f);
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) {
      const double dx = (x + 0.5) / 32.0 - 1.0, dy = 1.0 - (y + 0.5) / 32.0;
      const double r = std::hypot(dx, dy), t = std::atan2(dy, dx);
      const float v = r < 0.55 + 0.4 * std::cos(6.0 * t) ? 1.0f : 0.0f;
      for (int k = 0; k < 3; ++k) im.at(x, y, k) = v;
    }
  const std::string path =
      (std::filesystem::temp_directory_path() / "dofcache_aperture_bench_star.exr").string();
  image::write_image(path, im);
  return path;
}

int run(const Options& o) {
  lens::ApertureShape rim, stop, chromatic, tilt, shaped;
  rim.profile = lens::ApertureProfile::Rim;
  stop.stop = {0.03, 0.2};
  chromatic.axial_ca = 0.15, chromatic.lateral_ca = 0.01;
  tilt.tilt_x_deg = 2.0;
  shaped.image = star_image();
  const std::vector<Shape> shapes = {{"round", {}},
                                     {"6 blades", {6, 90.0, 0.0, 1.0}},
                                     {"6 blades, roundness 0.5", {6, 90.0, 0.5, 1.0}},
                                     {"anamorphic 2", {0, 0.0, 0.0, 2.0}},
                                     {"5 blades, anamorphic 1.5", {5, 0.0, 0.0, 1.5}},
                                     {"rim profile", rim},
                                     {"vignetting stop", stop},
                                     {"chromatic aberration", chromatic},
                                     {"tilt 2 deg", tilt},
                                     {"aperture image (star)", shaped}};
  const scene::Scene scene = render::load_scene(bench::scene_path("bokeh_lights.gltf"));
  const scene::Accel accel(scene);
  const scene::Camera& camera = scene.cameras[0];
  const render::RenderSettings base =
      bench::camera_settings(scene, accel, camera, o.width, o.spp, o.threads);

  std::vector<std::vector<double>> generate(shapes.size()), rendered(shapes.size());
  float sink = 0.0f;
  for (int round = 0; round < o.rounds; ++round)
    for (std::size_t k = 0; k < shapes.size(); ++k) {
      render::RenderSettings s = base;
      s.lens.aperture = shapes[k].shape;
      generate[k].push_back(bench::time_camera_rays(render::make_camera(camera, s), o.rays,
                                                    s.lens.aperture.chromatic(), &sink)
                                .seconds);
      rendered[k].push_back(render::render(scene, accel, camera, s).stats.seconds);
    }

  bench::Table table({"aperture", "ray generation [ns/ray]", "vs round", "cached render [s]",
                      "vs round"});
  const auto fastest = [](const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); };
  const double g0 = fastest(generate[0]), r0 = median(rendered[0]);
  for (std::size_t k = 0; k < shapes.size(); ++k) {
    const double g = fastest(generate[k]), r = median(rendered[k]);
    table.add_row({shapes[k].name, bench::Table::Cell(g / o.rays * 1e9, 2),
                   bench::Table::Cell(g / g0, 3), bench::Table::Cell(r, 3),
                   bench::Table::Cell(r / r0, 3)});
  }
  std::printf("Aperture shapes on bokeh_lights.gltf, %dx%d, %d spp, cached DRT (median); ray "
              "generation over %d rays, one thread (fastest); %d interleaved rounds (checksum "
              "%g)\n",
              base.width, base.height, o.spp, o.rays, o.rounds, static_cast<double>(sink));
  table.print();
  nlohmann::json results;
  results["scene"] = "bokeh_lights.gltf";
  results["width"] = base.width, results["height"] = base.height, results["spp"] = o.spp;
  results["rays"] = o.rays, results["rounds"] = o.rounds;
  bench::write_table(o.results, table, results);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{"What a shaped aperture costs against the round one: camera-ray generation and "
               "a whole cached render, side by side.",
               "aperture_bench"};
  bench::add_common_options(app, o.width, o.threads, o.results);
  bench::add_count_option(app, "--spp", o.spp, "Lens samples per pixel of the renders");
  bench::add_rays_option(app, o.rays);
  bench::add_count_option(app, "--rounds", o.rounds, "Interleaved rounds (the median is kept)");
  bench::parse_command_line(app, argc, argv);
  return bench::run_guarded(app, [&] { return run(o); });
}
