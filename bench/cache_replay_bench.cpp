// Replays a cache trace (the lookups and pass-end inserts of a render) against the radiance-cache
// backends: insert rate, lookup rate at 1 and 2 threads, memory. Without --trace it renders a
// synthetic trace: a thin-lens camera (50 mm f/1.4, focused at 3 m) looks at a floor, a back wall
// and four spheres from 1.2 m to 14 m, 480x360 pixels, 4 passes of 4 lens samples per pixel (the
// camera moves 10 cm after pass 2, as in a camera path), tile by tile; every hit is looked up,
// first in the cache, then in the tile's own TileSampleBuffer, and a miss creates a sample with
// the radius of eqs. (4.1)/(4.2). Only the cache lookups and the merged batches are recorded,
// which is what the renderer's --cache-trace writes.
//
//   cache_replay_bench [--trace FILE] [--write-trace FILE] [--results NAME]
//                      [--benchmark_NAME=VALUE...]   (--help for more)
//
// Prints a summary table and writes bench/results/cache_replay.{json,csv} (see bench/README.md).
#include <malloc.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <map>
#include <mutex>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <benchmark/benchmark.h>
#include <glm/geometric.hpp>

#include "bench_common.h"
#include "dofcache/cache/radiance_cache.h"
#include "dofcache/cache/sample_radius.h"
#include "dofcache/cache/tile_buffer.h"
#include "dofcache/cache/trace.h"
#include "dofcache/cache/vdb_cache.h"
#include "dofcache/core/rng.h"
#include "dofcache/lens/thin_lens.h"

using namespace dofcache;
using namespace dofcache::cache;

namespace {

// ---------------------------------------------------------------------------------------------
// Synthetic trace

struct Sphere {
  glm::vec3 centre;
  float radius;
};

struct SyntheticScene {
  float floor_y = -1.0f, wall_z = -16.0f;
  std::vector<Sphere> spheres = {{{-0.6f, -0.55f, -1.2f}, 0.45f},
                                 {{0.5f, -0.2f, -3.0f}, 0.8f},
                                 {{-1.8f, 0.3f, -6.5f}, 1.3f},
                                 {{3.0f, 1.0f, -14.0f}, 2.0f}};

  bool intersect(glm::vec3 o, glm::vec3 d, glm::vec3* p, glm::vec3* n) const {
    float best = INFINITY;
    if (d.y < 0.0f) {
      float t = (floor_y - o.y) / d.y;
      if (t > 0.0f && t < best) best = t, *n = {0, 1, 0};
    }
    if (d.z < 0.0f) {
      float t = (wall_z - o.z) / d.z;
      if (t > 0.0f && t < best) best = t, *n = {0, 0, 1};
    }
    for (const Sphere& s : spheres) {
      glm::vec3 oc = o - s.centre;
      float b = glm::dot(oc, d), c = glm::dot(oc, oc) - s.radius * s.radius;
      float disc = b * b - c;
      if (disc < 0.0f) continue;
      float t = -b - std::sqrt(disc);
      if (t > 1e-4f && t < best) best = t, *n = glm::normalize(o + t * d - s.centre);
    }
    if (!(best < INFINITY)) return false;
    *p = o + best * d;
    return true;
  }
};

// Smooth, view-independent stand-in for E / pi.
glm::vec3 shade(glm::vec3 p, glm::vec3 n) {
  float s = 0.5f + 0.4f * std::sin(2.0f * p.x) * std::cos(1.5f * p.z) + 0.1f * n.y;
  return {s, 0.8f * s, 0.6f + 0.2f * std::cos(p.y)};
}

CacheTrace synthetic_trace() {
  const int width = 480, height = 360, tile = 16, passes = 4, spp = 4;
  lens::LensImaging imaging;
  imaging.lens = {0.05, 1.4, 3.0};
  imaging.yfov = 0.7;
  imaging.y_resolution = height;
  const float tan_half = std::tan(0.5f * static_cast<float>(imaging.yfov));
  const float aspect = static_cast<float>(width) / height;
  const auto aperture = static_cast<float>(imaging.lens.aperture_radius());
  const auto focus = static_cast<float>(imaging.lens.focus_distance);
  SyntheticScene scene;

  CacheTrace trace;
  std::unique_ptr<RadianceCache> cache = make_radiance_cache("vdb");
  for (int pass = 0; pass < passes; ++pass) {
    TracePass out;
    const glm::vec3 eye(pass >= 2 ? 0.1f : 0.0f, 0.0f, 0.0f);
    const auto frame = static_cast<std::uint32_t>(pass / 2);
    for (int ty = 0; ty < height; ty += tile)
      for (int tx = 0; tx < width; tx += tile) {
        TileSampleBuffer buffer;
        for (int y = ty; y < std::min(ty + tile, height); ++y)
          for (int x = tx; x < std::min(tx + tile, width); ++x)
            for (int s = 0; s < spp; ++s) {
              Rng rng(hash_combine(static_cast<std::uint64_t>(y) * width + x, pass * spp + s));
              float px = (x + rng.uniform()) / width * 2.0f - 1.0f;
              float py = 1.0f - (y + rng.uniform()) / height * 2.0f;
              glm::vec3 dir(px * tan_half * aspect, py * tan_half, -1.0f);
              glm::vec3 on_focal_plane = eye + dir * focus;  // dir.z = -1
              glm::vec2 disk = lens::concentric_disk({rng.uniform(), rng.uniform()}) * aperture;
              glm::vec3 origin = eye + glm::vec3(disk, 0.0f);
              glm::vec3 p, n;
              if (!scene.intersect(origin, glm::normalize(on_focal_plane - origin), &p, &n))
                continue;
              out.lookups.push_back({p, n});
              if (cache->lookup(p, n, trace.options, nullptr)) continue;
              if (buffer.lookup(p, n, trace.options, nullptr)) continue;
              CacheSample sample;
              sample.position = p;
              sample.normal = n;
              sample.value = shade(p, n);
              sample.radius = static_cast<float>(sample_radius(imaging, eye.z - p.z));
              sample.frame = frame;
              buffer.add(sample);
            }
        buffer.append_to(&out.inserts);
      }
    cache->insert(out.inserts);
    trace.passes.push_back(std::move(out));
  }
  return trace;
}

// ---------------------------------------------------------------------------------------------
// Replay

CacheTrace g_trace;

struct Backend {
  std::string name;
  std::function<std::unique_ptr<RadianceCache>()> make;
};

const std::vector<Backend>& backends() {
  static const std::vector<Backend> list = {
      {"octree", [] { return make_radiance_cache("octree"); }},
      {"vdb", [] { return make_radiance_cache("vdb"); }},  // cell_scale 4
      {"vdb_cell1", [] { return make_vdb_radiance_cache({1.0f}); }},
      {"vdb_cell2", [] { return make_vdb_radiance_cache({2.0f}); }},
  };
  return list;
}

std::size_t heap_in_use() { return mallinfo2().uordblks + mallinfo2().hblkhd; }

// snapshots[j]: the cache as pass j saw it (the batches of passes 0..j-1 inserted).
struct Replay {
  std::vector<std::unique_ptr<RadianceCache>> snapshots;
  std::size_t final_bytes = 0, final_heap = 0, final_size = 0;
};

Replay& replay(const Backend& backend) {
  static std::map<std::string, Replay> replays;
  Replay& r = replays[backend.name];
  if (!r.snapshots.empty()) return r;
  for (std::size_t j = 0; j < g_trace.passes.size(); ++j) {
    auto c = backend.make();
    for (std::size_t k = 0; k < j; ++k) c->insert(g_trace.passes[k].inserts);
    r.snapshots.push_back(std::move(c));
  }
  // Memory of the full cache, by its own count and by the allocator's.
  std::size_t before = heap_in_use();
  auto full = backend.make();
  for (const TracePass& pass : g_trace.passes) full->insert(pass.inserts);
  r.final_heap = heap_in_use() - before;
  r.final_bytes = full->memory_bytes();
  r.final_size = full->size();
  return r;
}

struct Row {
  double lookups_per_s = 0, lookups_per_cpu_s = 0, inserts_per_s = 0, hit_rate = 0;
};
std::map<std::string, std::map<int, Row>> g_rows;  // backend -> threads -> numbers

double thread_cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// All lookups of the trace, each pass against its snapshot, spread over `threads` threads that
// take blocks of 1024 consecutive lookups (a few tiles) from a shared counter, as a renderer's
// tile scheduler would. Adds the CPU time all threads spent to *cpu_seconds: on a machine shared
// with other work, lookups per CPU-second show whether threads slow each other down even when the
// wall clock cannot show the speed-up.
std::size_t run_lookups(const Replay& r, int threads, double* cpu_seconds) {
  std::atomic<std::size_t> hits{0};
  std::mutex cpu_mutex;
  for (std::size_t j = 0; j < g_trace.passes.size(); ++j) {
    const std::vector<TraceLookup>& lookups = g_trace.passes[j].lookups;
    const RadianceCache& cache = *r.snapshots[j];
    std::atomic<std::size_t> next{0};
    auto work = [&] {
      double cpu_start = thread_cpu_seconds();
      std::size_t local = 0;
      for (;;) {
        std::size_t begin = next.fetch_add(1024);
        if (begin >= lookups.size()) break;
        std::size_t end = std::min(begin + 1024, lookups.size());
        for (std::size_t i = begin; i < end; ++i) {
          LookupResult res;
          local += cache.lookup(lookups[i].position, lookups[i].normal, g_trace.options, &res);
          benchmark::DoNotOptimize(res);
        }
      }
      hits += local;
      std::lock_guard<std::mutex> lock(cpu_mutex);
      *cpu_seconds += thread_cpu_seconds() - cpu_start;
    };
    std::vector<std::thread> pool;
    for (int t = 1; t < threads; ++t) pool.emplace_back(work);
    work();
    for (std::thread& t : pool) t.join();
  }
  return hits;
}

void BM_Lookup(benchmark::State& state, const Backend& backend) {
  const Replay& r = replay(backend);
  int threads = static_cast<int>(state.range(0));
  std::size_t hits = 0;
  double cpu = 0.0;
  for (auto _ : state) hits = run_lookups(r, threads, &cpu);
  double n = static_cast<double>(g_trace.lookup_count());
  state.counters["lookups_per_cpu_s"] = n * static_cast<double>(state.iterations()) / cpu;
  state.counters["lookups_per_s"] =
      benchmark::Counter(n, benchmark::Counter::kIsIterationInvariantRate);
  state.counters["hit_rate"] = static_cast<double>(hits) / n;
  state.counters["bytes"] = static_cast<double>(r.final_bytes);
  state.counters["heap_bytes"] = static_cast<double>(r.final_heap);
  state.counters["samples"] = static_cast<double>(r.final_size);
}

void BM_Insert(benchmark::State& state, const Backend& backend) {
  for (auto _ : state) {
    auto c = backend.make();
    for (const TracePass& pass : g_trace.passes) c->insert(pass.inserts);
    benchmark::DoNotOptimize(c->size());
  }
  state.counters["inserts_per_s"] = benchmark::Counter(
      static_cast<double>(g_trace.insert_count()), benchmark::Counter::kIsIterationInvariantRate);
}

void BM_TileBuffer(benchmark::State& state) {
  // A tile's worth of samples (the largest tile buffer of the trace's first pass is about this
  // size) and lookups around them.
  const std::vector<CacheSample>& batch = g_trace.passes[0].inserts;
  std::size_t count = static_cast<std::size_t>(state.range(0));
  TileSampleBuffer tile;
  for (std::size_t i = 0; i < count && i < batch.size(); ++i) tile.add(batch[i]);
  std::size_t k = 0;
  for (auto _ : state) {
    const CacheSample& s = batch[k++ % std::min(count, batch.size())];
    LookupResult r;
    benchmark::DoNotOptimize(tile.lookup(s.position + 0.3f * s.radius, s.normal, {}, &r));
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()));
}

// Collects the final numbers of each benchmark run for the summary table.
class SummaryReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& run : runs) {
      std::string name = run.benchmark_name();
      auto counter = [&](const char* key) {
        auto it = run.counters.find(key);
        return it == run.counters.end() ? 0.0 : it->second.value;  // already finalised
      };
      for (const Backend& b : backends()) {
        std::string lookup = "lookup/" + b.name + "/";  // then "<threads>/real_time"
        if (name.rfind(lookup, 0) == 0) {
          int threads = std::stoi(name.substr(lookup.size()));
          Row& row = g_rows[b.name][threads];
          row.lookups_per_s = counter("lookups_per_s");
          row.lookups_per_cpu_s = counter("lookups_per_cpu_s");
          row.hit_rate = counter("hit_rate");
        } else if (name == "insert/" + b.name || name.rfind("insert/" + b.name + "/", 0) == 0) {
          g_rows[b.name][0].inserts_per_s = counter("inserts_per_s");
        }
      }
    }
    ConsoleReporter::ReportRuns(runs);
  }
};

// Every lookup of the trace gives bit-identical answers on every backend.
std::size_t verify_backends() {
  std::size_t checked = 0;
  std::vector<Replay*> all;
  for (const Backend& b : backends()) all.push_back(&replay(b));
  for (std::size_t j = 0; j < g_trace.passes.size(); ++j)
    for (const TraceLookup& l : g_trace.passes[j].lookups) {
      LookupResult ref;
      bool ok = all[0]->snapshots[j]->lookup(l.position, l.normal, g_trace.options, &ref);
      for (std::size_t k = 1; k < all.size(); ++k) {
        LookupResult r;
        bool ok_k = all[k]->snapshots[j]->lookup(l.position, l.normal, g_trace.options, &r);
        if (ok_k != ok || r.count != ref.count || std::memcmp(&r.value, &ref.value, 12) != 0) {
          std::fprintf(stderr, "cache_replay: %s and %s differ at a lookup of pass %zu\n",
                       backends()[0].name.c_str(), backends()[k].name.c_str(), j);
          std::exit(1);
        }
      }
      ++checked;
    }
  return checked;
}

struct Options {
  std::string trace_path, write_path;
  std::string results = "cache_replay";
};

int run(const Options& o) {
  g_trace = o.trace_path.empty() ? synthetic_trace() : read_trace(o.trace_path);
  if (!o.write_path.empty()) write_trace(o.write_path, g_trace);
  std::printf("trace: %s, %zu passes, %zu lookups, %zu inserts\n",
              o.trace_path.empty() ? "synthetic" : o.trace_path.c_str(), g_trace.passes.size(),
              g_trace.lookup_count(), g_trace.insert_count());
  std::printf("verified: %zu lookups bit-identical on every backend\n", verify_backends());

  for (const Backend& b : backends()) {
    benchmark::RegisterBenchmark(("insert/" + b.name).c_str(), BM_Insert, b)
        ->Unit(benchmark::kMillisecond);  // one thread: rate per CPU-second
    benchmark::RegisterBenchmark(("lookup/" + b.name).c_str(), BM_Lookup, b)
        ->Arg(1)
        ->Arg(2)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime();
  }
  benchmark::RegisterBenchmark("tile_buffer_lookup", BM_TileBuffer)->Arg(64)->Arg(256)->Arg(512);
  SummaryReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::Shutdown();
  if (g_rows.empty()) {  // --benchmark_list_tests, or a filter that matched nothing
    std::printf("no benchmark ran: %s not written\n", o.results.c_str());
    return 0;
  }

  // Rates per CPU-second are what to compare on a machine shared with other work; the wall-clock
  // rates (and 2T/1T) need an otherwise idle machine.
  bench::Table table({"backend", "samples", "bytes", "bytes/sample", "heap bytes", "inserts/s",
                      "lookups/s 1T", "lookups/s 2T", "2T/1T", "lookups/cpu-s 1T",
                      "2T/1T per cpu-s", "vs octree (cpu-s)", "hit rate"},
                     2);
  double octree_cpu_rate = g_rows["octree"][1].lookups_per_cpu_s;
  for (const Backend& b : backends()) {
    const Replay& r = replay(b);
    auto& rows = g_rows[b.name];
    double one = rows[1].lookups_per_s, two = rows[2].lookups_per_s;
    double one_cpu = rows[1].lookups_per_cpu_s, two_cpu = rows[2].lookups_per_cpu_s;
    table.add_row({b.name, static_cast<std::int64_t>(r.final_size),
                   static_cast<std::int64_t>(r.final_bytes),
                   bench::Table::Cell(static_cast<double>(r.final_bytes) / r.final_size, 1),
                   static_cast<std::int64_t>(r.final_heap),
                   bench::Table::Cell(rows[0].inserts_per_s, 0), bench::Table::Cell(one, 0),
                   bench::Table::Cell(two, 0), one > 0 ? two / one : 0.0,
                   bench::Table::Cell(one_cpu, 0), one_cpu > 0 ? two_cpu / one_cpu : 0.0,
                   octree_cpu_rate > 0 ? one_cpu / octree_cpu_rate : 0.0,
                   bench::Table::Cell(rows[1].hit_rate, 4)});
  }
  table.print();
  nlohmann::json results = {
      {"trace", o.trace_path.empty() ? "synthetic" : o.trace_path},
      {"lookups", g_trace.lookup_count()},
      {"inserts", g_trace.insert_count()},
      {"passes", g_trace.passes.size()},
      {"columns", table.header()},
      {"rows", table.to_json()}};
  std::printf("wrote %s\n", bench::write_results(o.results, results).c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{"Replays a radiance-cache trace against the cache backends: insert and lookup "
               "rates at 1 and 2 threads, memory.",
               "cache_replay_bench"};
  app.add_option("--trace", o.trace_path,
                 "A trace written by the renderer's --cache-trace (default: render the synthetic "
                 "trace)")
      ->check(CLI::ExistingFile);
  app.add_option("--write-trace", o.write_path, "Also save the replayed trace to this file");
  bench::add_results_option(app, o.results);
  bench::parse_benchmark_command_line(app, argc, argv);
  return bench::run_guarded(app, [&] { return run(o); });
}
