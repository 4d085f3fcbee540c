// Scale: a production-sized scene (scenes/generate_atrium.py, ~2.1 M triangles, 11 textures)
// loaded, its BVH built and rendered. Measures glTF load time, Embree scene commit time, memory
// (peak resident set, the scene's arrays per triangle, Embree's own BVH per triangle) and render
// throughput. Prints a table and writes bench/results/scene_scale.{json,csv}.
//   scene_scale_bench [--scene FILE | --triangles N] [--width W] [--spp N] [--threads T]
#include <embree3/rtcore.h>
#include <malloc.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <fmt/format.h>
#include <tbb/global_control.h>

#include "bench_common.h"
#include "dofcache/core/error.h"
#include "dofcache/core/stopwatch.h"
#include "dofcache/render/renderer.h"
#include "dofcache/render/setup.h"
#include "dofcache/scene/accel.h"

using namespace dofcache;
namespace fs = std::filesystem;

namespace {

struct Options {
  std::string scene;  // empty: generate the atrium
  int triangles = 2'100'000;
  int width = 320, spp = 4, threads = 2;
  int load_repeats = 3;  // the load is timed this often, the fastest kept (a shared machine)
  std::string results = "scene_scale";
};

// Peak resident set of the process so far (Linux reports kilobytes).
double peak_rss_bytes() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return double(usage.ru_maxrss) * 1024.0;
}

// Resident set now, from /proc/self/statm (pages). malloc_trim first: glibc keeps memory freed
// by earlier loads (its mmap threshold grows after large frees), which is not the scene's.
double rss_bytes() {
  malloc_trim(0);
  std::ifstream statm("/proc/self/statm");
  double size = 0, resident = 0;
  statm >> size >> resident;
  return resident * double(sysconf(_SC_PAGESIZE));
}

template <class T>
double bytes(const std::vector<T>& v) {
  return double(v.capacity() * sizeof(T));
}

// What the scene's arrays hold (capacity, not size: what the allocator gave them).
nlohmann::json scene_memory(const scene::Scene& s) {
  const scene::Mesh& m = s.mesh;
  double texels = 0;
  for (const scene::Texture& t : s.textures) texels += bytes(t.texels);
  return {{"positions", bytes(m.positions)},         {"normals", bytes(m.normals)},
          {"uv0", bytes(m.uv0)},                     {"uv1", bytes(m.uv1)},
          {"colors", bytes(m.colors)},               {"tangents", bytes(m.tangents)},
          {"triangles", bytes(m.triangles)},         {"triangle_material", bytes(m.triangle_material)},
          {"triangle_object", bytes(m.triangle_object)}, {"emitters", bytes(s.emitters)},
          {"textures", texels}};
}

// Embree's own need for this mesh: a device of its own whose memory monitor counts every byte
// Embree allocates, one triangle geometry sharing the scene's buffers, built with the settings of
// scene::Accel (robust, high quality). The peak includes the builder's temporary memory; the
// final count is what the BVH keeps.
struct EmbreeMemory {
  double final_bytes = 0, peak_bytes = 0, seconds = 0;
};

EmbreeMemory embree_memory(const scene::Scene& s) {
  struct Counter {
    std::atomic<long long> now{0}, peak{0};
  } counter;
  RTCDevice device = rtcNewDevice(nullptr);
  if (!device) throw Error("Embree: cannot create a device");
  rtcSetDeviceMemoryMonitorFunction(
      device,
      [](void* user, ssize_t delta, bool) {
        auto* c = static_cast<Counter*>(user);
        long long now = c->now += delta;
        long long peak = c->peak.load();
        while (now > peak && !c->peak.compare_exchange_weak(peak, now)) {
        }
        return true;
      },
      &counter);
  RTCScene scene = rtcNewScene(device);
  rtcSetSceneFlags(scene, RTC_SCENE_FLAG_ROBUST);
  rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_HIGH);
  RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  rtcSetGeometryBuildQuality(geom, RTC_BUILD_QUALITY_HIGH);
  // The loader leaves readable room after the last vertex for Embree's 16-byte loads.
  rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                             s.mesh.positions.data(), 0, 3 * sizeof(float),
                             s.mesh.positions.size());
  rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                             s.mesh.triangles.data(), 0, 3 * sizeof(std::uint32_t),
                             s.mesh.triangles.size());
  rtcCommitGeometry(geom);
  rtcAttachGeometry(scene, geom);
  rtcReleaseGeometry(geom);
  const auto start = std::chrono::steady_clock::now();
  rtcCommitScene(scene);
  EmbreeMemory result;
  result.seconds = seconds_since(start);
  const RTCError error = rtcGetDeviceError(device);
  result.final_bytes = double(counter.now.load());
  result.peak_bytes = double(counter.peak.load());
  rtcReleaseScene(scene);
  rtcReleaseDevice(device);
  if (error != RTC_ERROR_NONE) throw Error("Embree: building the BVH failed");
  return result;
}

std::string generate_atrium(int triangles) {
  const fs::path dir = fs::temp_directory_path() / ("dofcache_scene_scale_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const std::string file = (dir / "atrium.glb").string();
  const std::string command = "python3 '" + std::string(DOFCACHE_SOURCE_DIR) +
                              "/scenes/generate_atrium.py' '" + file + "' --triangles " +
                              std::to_string(triangles) + " > /dev/null";
  std::fprintf(stderr, "generating %s (%d triangles) ...\n", file.c_str(), triangles);
  if (std::system(command.c_str()) != 0) throw Error("cannot generate the scene: " + command);
  return file;
}

int run(const Options& o) {
  const bool generated = o.scene.empty();
  const std::string file = generated ? generate_atrium(o.triangles) : o.scene;
  const double file_bytes = double(fs::file_size(file));
  const double rss_start = rss_bytes();

  // The load on one thread and on all (the loader's parallel loops), alternately so both meet
  // the same machine; the fastest of each kept. Both must give the same scene.
  double load_seconds = 1e30, serial_load_seconds = 1e30;
  std::uint64_t serial_hash = 0;
  for (int r = 1; r < o.load_repeats; ++r) {
    {
      tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
      const auto start = std::chrono::steady_clock::now();
      serial_hash = render::load_scene(file).content_hash;
      serial_load_seconds = std::min(serial_load_seconds, seconds_since(start));
    }
    const auto start = std::chrono::steady_clock::now();
    render::load_scene(file);
    load_seconds = std::min(load_seconds, seconds_since(start));
  }
  auto start = std::chrono::steady_clock::now();
  scene::Scene scene = render::load_scene(file);
  load_seconds = std::min(load_seconds, seconds_since(start));
  if (o.load_repeats > 1 && serial_hash != scene.content_hash)
    throw Error("the scene loaded on one thread differs from the one loaded on all");
  const double rss_loaded = rss_bytes(), peak_loaded = peak_rss_bytes();

  start = std::chrono::steady_clock::now();
  scene::Accel accel(scene);
  const double bvh_seconds = seconds_since(start);
  const double rss_accel = rss_bytes(), peak_accel = peak_rss_bytes();

  const EmbreeMemory embree = embree_memory(scene);

  const scene::Camera& camera = scene.cameras[0];
  const render::RenderSettings s =
      bench::camera_settings(scene, accel, camera, o.width, o.spp, o.threads);
  const render::RenderStats st = render::render(scene, accel, camera, s).stats;
  if (generated) fs::remove_all(fs::path(file).parent_path());

  const double triangles = double(scene.mesh.triangles.size());
  const nlohmann::json memory = scene_memory(scene);
  double scene_bytes = 0, geometry_bytes = 0;
  for (const auto& [name, value] : memory.items()) {
    scene_bytes += value.get<double>();
    if (name != "textures") geometry_bytes += value.get<double>();
  }
  const double MB = 1e-6;
  bench::Table table({"scene", "triangles", "vertices", "textures", "file [MB]",
                      "load 1 thread [s]", "load [s]",
                      "BVH [s]", "scene [MB]", "geometry [B/tri]", "Embree BVH [B/tri]",
                      "Embree peak [B/tri]", "accel RSS [B/tri]", "peak RSS [MB]", "render",
                      "render [s]", "Mcamera rays/s", "Mrays/s", "ksamples/s"});
  table.add_row({fs::path(file).filename().string(), static_cast<long>(triangles),
                 static_cast<long>(scene.mesh.positions.size()),
                 static_cast<long>(scene.textures.size()), bench::Table::Cell(file_bytes * MB, 1),
                 o.load_repeats > 1 ? bench::Table::Cell(serial_load_seconds, 2)
                                    : bench::Table::Cell(std::nan("")),
                 bench::Table::Cell(load_seconds, 2), bench::Table::Cell(bvh_seconds, 2),
                 bench::Table::Cell(scene_bytes * MB, 1),
                 bench::Table::Cell(geometry_bytes / triangles, 1),
                 bench::Table::Cell(embree.final_bytes / triangles, 1),
                 bench::Table::Cell(embree.peak_bytes / triangles, 1),
                 bench::Table::Cell((rss_accel - rss_loaded) / triangles, 1),
                 bench::Table::Cell(peak_rss_bytes() * MB, 0),
                 std::to_string(s.width) + "x" + std::to_string(s.height) + " " +
                     std::to_string(o.spp) + " spp " + std::to_string(st.threads) + " thr",
                 bench::Table::Cell(st.seconds, 2),
                 bench::Table::Cell(double(st.camera_rays) / st.seconds * 1e-6, 3),
                 bench::Table::Cell(st.rays_per_second() * 1e-6, 3),
                 bench::Table::Cell(double(s.width) * s.height * o.spp / st.seconds * 1e-3, 1)});
  table.print();
  std::printf("scene memory by array [MB]:");
  for (const auto& [name, value] : memory.items())
    std::printf(" %s %.1f", name.c_str(), value.get<double>() * MB);
  std::printf("\ncontent hash %016llx\n", static_cast<unsigned long long>(scene.content_hash));
  std::printf("resident set [MB]: start %.0f, after load %.0f (peak %.0f), after BVH %.0f (peak "
              "%.0f); Embree alone: BVH %.1f MB, peak during build %.1f MB, build %.2f s\n",
              rss_start * MB, rss_loaded * MB, peak_loaded * MB, rss_accel * MB, peak_accel * MB,
              embree.final_bytes * MB, embree.peak_bytes * MB, embree.seconds);

  nlohmann::json results;
  results["scene_memory_bytes"] = memory;
  results["content_hash"] = fmt::format("{:016x}", scene.content_hash);
  results["resident_set_bytes"] = {{"start", rss_start},       {"after_load", rss_loaded},
                                   {"peak_after_load", peak_loaded}, {"after_bvh", rss_accel},
                                   {"peak_after_bvh", peak_accel}, {"peak_end", peak_rss_bytes()}};
  results["embree_alone"] = {{"bvh_bytes", embree.final_bytes},
                             {"peak_bytes", embree.peak_bytes},
                             {"build_seconds", embree.seconds}};
  results["render"] = {{"width", s.width},          {"height", s.height},
                       {"spp", o.spp},              {"threads", st.threads},
                       {"seconds", st.seconds},     {"camera_rays", st.camera_rays},
                       {"rays", st.rays},           {"shading_points", st.shading_points}};
  results["generated"] = generated ? nlohmann::json{{"triangles_requested", o.triangles}}
                                   : nlohmann::json(nullptr);
  double load[3] = {0, 0, 0};
  if (getloadavg(load, 3) == 3) results["load_average"] = {load[0], load[1], load[2]};
  bench::write_table(o.results, table, results);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{"Load time, BVH build time, memory and render throughput of a production-sized "
               "scene (scenes/generate_atrium.py, generated unless --scene is given).",
               "scene_scale_bench"};
  bench::add_common_options(app, o.width, o.threads, o.results);
  bench::add_count_option(app, "--spp", o.spp, "Lens samples per pixel");
  app.add_option("--scene", o.scene, "A .gltf/.glb to measure instead of generating the atrium")
      ->type_name("FILE")
      ->check(CLI::ExistingFile);
  bench::add_count_option(app, "--load-repeats", o.load_repeats,
                          "Loads timed on all threads, and one fewer on one thread (the fastest "
                          "of each is reported; the peak resident set includes them)");
  app.add_option("--triangles", o.triangles, "Triangles of the generated atrium (about)")
      ->check(bench::in_range(5000, 50'000'000));
  bench::parse_command_line(app, argc, argv);
  return bench::run_guarded(app, [&] { return run(o); });
}
