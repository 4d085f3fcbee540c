// Reference renderer throughput: each shipped scene rendered with distributed ray tracing at a
// fixed small size. Prints a table and writes bench/results/render_drt.{json,csv}.
//   render_drt_bench [--width W] [--spp N] [--threads T]
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "bench_common.h"
#include "dofcache/render/renderer.h"
#include "dofcache/render/setup.h"
#include "dofcache/scene/accel.h"

using namespace dofcache;

int main(int argc, char** argv) {
  int width = 160, spp = 16, threads = 0;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--width")) width = std::atoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--spp")) spp = std::atoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--threads")) threads = std::atoi(argv[i + 1]);
  }
  const char* scenes[] = {"cornell_box.gltf", "color_bars.gltf", "color_spheres.gltf",
                          "glossy_closeup.glb"};
  bench::Table table({"scene", "triangles", "size", "spp", "threads", "time [s]", "Mrays/s",
                      "rays/camera ray", "shading points"});
  render::ShadingSettings shading;  // the defaults: what a user gets
  for (const char* name : scenes) {
    std::string path = std::string(DOFCACHE_SOURCE_DIR) + "/scenes/" + name;
    scene::Scene scene = render::load_scene(path);
    scene::Accel accel(scene);
    const scene::Camera& camera = scene.cameras[0];
    render::RenderSettings s;
    s.width = width;
    s.height = render::height_for_width(camera, width);
    s.spp = spp;
    s.threads = threads;
    s.shading = shading;
    s.lens = render::resolve_lens(scene, accel, camera, {}).lens;
    s.progress = Progress::Display::Never;
    render::RenderOutput out = render::render(scene, accel, camera, s);
    const render::RenderStats& st = out.stats;
    table.add_row({name, static_cast<long>(scene.mesh.triangles.size()),
                   std::to_string(s.width) + "x" + std::to_string(s.height), spp, st.threads,
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
  results["rows"] = table.to_json();
  results["columns"] = table.header();
  std::printf("wrote %s\n", bench::write_results("render_drt", results).c_str());
  return 0;
}
