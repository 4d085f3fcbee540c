// Reference renderer throughput: each shipped scene rendered with distributed ray tracing at a
// fixed small size. Prints a table and writes bench/results/render_drt.{json,csv}.
//   render_drt_bench [--width W] [--spp N] [--threads T] [--results NAME]   (--help for more)
#include <cstdio>
#include <string>

#include "bench_common.h"
#include "dofcache/render/renderer.h"
#include "dofcache/render/setup.h"
#include "dofcache/scene/accel.h"

using namespace dofcache;

namespace {

struct Options {
  int width = 160, spp = 16, threads = 0;
  std::string results = "render_drt";
};

int run(const Options& o) {
  const char* scenes[] = {"cornell_box.gltf", "color_bars.gltf", "color_spheres.gltf",
                          "glossy_closeup.glb"};
  bench::Table table({"scene", "triangles", "size", "spp", "threads", "time [s]", "Mrays/s",
                      "rays/camera ray", "shading points"});
  render::ShadingSettings shading;  // the defaults: what a user gets
  for (const char* name : scenes) {
    scene::Scene scene = render::load_scene(bench::scene_path(name));
    scene::Accel accel(scene);
    const scene::Camera& camera = scene.cameras[0];
    render::RenderSettings s =
        bench::camera_settings(scene, accel, camera, o.width, o.spp, o.threads);
    s.shading = shading;
    render::RenderOutput out = render::render(scene, accel, camera, s);
    const render::RenderStats& st = out.stats;
    table.add_row({name, static_cast<long>(scene.mesh.triangles.size()),
                   std::to_string(s.width) + "x" + std::to_string(s.height), o.spp, st.threads,
                   bench::Table::Cell(st.seconds, 2), bench::Table::Cell(st.rays_per_second() * 1e-6, 2),
                   bench::Table::Cell(double(st.rays) / double(st.camera_rays), 1),
                   static_cast<long>(st.shading_points)});
  }
  std::printf("Distributed ray tracing, default shading (light samples %d, gather rays %d, "
              "bounces %d)\n",
              shading.light_samples, shading.gather_rays, shading.bounces);
  table.print();
  nlohmann::json results;
  results["shading"] = {{"light_samples", shading.light_samples},
                        {"gather_rays", shading.gather_rays}, {"bounces", shading.bounces}};
  bench::write_table(o.results, table, results);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{"Distributed ray tracing throughput on each shipped scene (default shading).",
               "render_drt_bench"};
  bench::add_common_options(app, o.width, o.threads, o.results);
  bench::add_count_option(app, "--spp", o.spp, "Lens samples per pixel");
  bench::parse_command_line(app, argc, argv);
  return bench::run_guarded(app, [&] { return run(o); });
}
