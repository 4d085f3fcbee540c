// The radiance-cache backends as data structures from 100 k to 10 M samples, on traces recorded
// from real renders (the renderer's --cache-trace). A trace of one render holds a few hundred
// thousand samples; larger caches are made by replaying it k times side by side (copy i shifted
// along x by i times the trace's extent plus a margin, so no copy reaches another): the local
// structure stays the real render's, while the cache, its trees and its memory grow k-fold, which
// is what a longer camera path or a larger image does to them.
//
// For each size and backend, the passes are replayed as the renderer runs them: a pass's lookups
// against the cache as it stands, then its batch inserted. Lookups and inserts are timed in CPU
// seconds on one thread (the machine may be shared); the backends run one after the other in the
// same process, so their ratios are side by side, in --repeat rounds (3) whose medians are
// reported: single runs of a few seconds scatter by up to a fifth. Every lookup's answer (hit,
// count, value) is hashed, and the hashes of the backends must agree: they are compared as
// structures, on the same answers.
//
//   cache_sweep_bench --trace FILE [--trace FILE ...] [--samples N ...] [--repeat R]
//                     [--results NAME]
//
// Prints a table and writes bench/results/NAME.{json,csv}; bench/plot_cache_sweep.py draws it.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "bench_common.h"
#include "dofcache/cache/radiance_cache.h"
#include "dofcache/cache/trace.h"
#include "dofcache/core/error.h"
#include "dofcache/core/rng.h"

using namespace dofcache;
using namespace dofcache::cache;

namespace {

double cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

struct Copies {
  int count = 1;
  float shift = 0.0f;  // along x, per copy
};

// The shift that keeps copies apart: the extent of everything the trace touches along x, plus
// twice the largest radius.
float copy_shift(const CacheTrace& trace) {
  float lo = INFINITY, hi = -INFINITY, r_max = 0.0f;
  for (const TracePass& pass : trace.passes) {
    for (const TraceLookup& l : pass.lookups) {
      lo = std::min(lo, l.position.x);
      hi = std::max(hi, l.position.x);
    }
    for (const CacheSample& s : pass.inserts) {
      lo = std::min(lo, s.position.x - s.radius);
      hi = std::max(hi, s.position.x + s.radius);
      r_max = std::max(r_max, s.radius);
    }
  }
  if (!(hi >= lo)) return 1.0f;
  return (hi - lo) + 2.0f * r_max + 1e-3f * std::max(1.0f, std::abs(hi) + std::abs(lo));
}

struct Measured {
  std::size_t samples = 0, bytes = 0, lookups = 0, hits = 0;
  double lookup_cpu = 0.0, insert_cpu = 0.0;
  std::uint64_t answers = 0;  // hash of every lookup's answer
};

Measured replay(const std::string& backend, const CacheTrace& trace, const Copies& copies) {
  std::unique_ptr<RadianceCache> cache = make_radiance_cache(backend);
  Measured m;
  std::vector<CacheSample> batch;
  for (const TracePass& pass : trace.passes) {
    double t0 = cpu_seconds();
    for (int c = 0; c < copies.count; ++c) {
      const glm::vec3 offset(copies.shift * static_cast<float>(c), 0.0f, 0.0f);
      for (const TraceLookup& l : pass.lookups) {
        LookupResult r;
        const bool hit = cache->lookup(l.position + offset, l.normal, trace.options, &r);
        m.hits += hit;
        std::uint32_t bits[3];
        std::memcpy(bits, &r.value, sizeof(bits));
        m.answers = hash_combine(m.answers, (std::uint64_t{bits[0]} << 32) | bits[1]);
        m.answers = hash_combine(
            m.answers, (std::uint64_t{bits[2]} << 32) | static_cast<std::uint32_t>(r.count) << 1 | hit);
      }
    }
    m.lookup_cpu += cpu_seconds() - t0;
    m.lookups += pass.lookups.size() * static_cast<std::size_t>(copies.count);
    batch.clear();
    for (int c = 0; c < copies.count; ++c)
      for (CacheSample s : pass.inserts) {
        s.position.x += copies.shift * static_cast<float>(c);
        batch.push_back(s);
      }
    t0 = cpu_seconds();
    cache->insert(batch);
    m.insert_cpu += cpu_seconds() - t0;
  }
  m.samples = cache->size();
  m.bytes = cache->memory_bytes();
  return m;
}

struct Options {
  std::vector<std::string> traces;
  std::vector<double> samples = {1e5, 3e5, 1e6, 3e6, 1e7};
  std::vector<std::string> backends = {"octree", "vdb"};
  int repeat = 3;
  std::string results = "cache_sweep";
};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

int run(const Options& o) {
  // Rates are medians over the rounds; a ratio is the median of the rounds' ratios (each round
  // runs every backend once, one after the other, so a ratio compares runs close in time), with
  // the rounds' smallest and largest beside it.
  bench::Table table({"trace", "copies", "samples", "backend", "bytes/sample",
                      "lookups/cpu-s", "inserts/cpu-s", "hit rate", "vdb/octree lookups",
                      "ratio min", "ratio max", "vdb/octree bytes"},
                     3);
  for (const std::string& path : o.traces) {
    const CacheTrace trace = read_trace(path);
    const std::size_t base = trace.insert_count();
    if (base == 0) throw Error(path + ": the trace inserts no sample");
    const float shift = copy_shift(trace);
    const std::string name = std::filesystem::path(path).stem().string();
    std::printf("%s: %zu passes, %zu lookups, %zu samples; copies %g apart\n", name.c_str(),
                trace.passes.size(), trace.lookup_count(), base, shift);
    int last_copies = 0;
    for (double target : o.samples) {
      const int copies = std::max(1, static_cast<int>(std::lround(target / base)));
      if (copies == last_copies) continue;
      last_copies = copies;
      // rounds[r][b]: backend b in round r.
      std::vector<std::vector<Measured>> rounds(static_cast<std::size_t>(o.repeat));
      for (auto& round : rounds)
        for (const std::string& backend : o.backends) {
          round.push_back(replay(backend, trace, {copies, shift}));
          if (round.back().answers != rounds.front().front().answers)
            throw Error(name + ": " + backend + " and " + o.backends.front() +
                        " answer lookups differently");
        }
      auto lookup_rate = [](const Measured& m) { return m.lookups / m.lookup_cpu; };
      const Measured& first = rounds.front().front();
      for (std::size_t b = 0; b < o.backends.size(); ++b) {
        const Measured& m = rounds.front()[b];  // sizes and hits are the same in every round
        std::vector<double> lookups, inserts, ratios;
        for (const auto& round : rounds) {
          lookups.push_back(lookup_rate(round[b]));
          inserts.push_back(round[b].samples / round[b].insert_cpu);
          ratios.push_back(lookup_rate(round[b]) / lookup_rate(round.front()));
        }
        table.add_row({name, copies, static_cast<std::int64_t>(m.samples), o.backends[b],
                       bench::Table::Cell(static_cast<double>(m.bytes) / m.samples, 1),
                       bench::Table::Cell(median(lookups), 0),
                       bench::Table::Cell(median(inserts), 0),
                       bench::Table::Cell(static_cast<double>(m.hits) / m.lookups, 4),
                       bench::Table::Cell(median(ratios), 2),
                       bench::Table::Cell(*std::min_element(ratios.begin(), ratios.end()), 2),
                       bench::Table::Cell(*std::max_element(ratios.begin(), ratios.end()), 2),
                       bench::Table::Cell(static_cast<double>(m.bytes) / first.bytes, 2)});
      }
      std::fflush(stdout);
    }
  }
  table.print();
  nlohmann::json results = {{"traces", o.traces},
                            {"repeat", o.repeat},
                            {"columns", table.header()},
                            {"rows", table.to_json()}};
  std::printf("wrote %s\n", bench::write_results(o.results, results).c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{"The cache backends as data structures from 100 k to 10 M samples: lookups and "
               "inserts per CPU-second and bytes per sample, on real render traces replayed "
               "side by side k times.",
               "cache_sweep_bench"};
  app.add_option("--trace", o.traces, "A trace written by dofcache render --cache-trace (repeat)")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("--samples", o.samples, "Cache sizes to reach (rounded to whole copies)")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 1e9));
  app.add_option("--backend", o.backends, "Backends, the first the reference of the ratios")
      ->capture_default_str();
  app.add_option("--repeat", o.repeat,
                 "Rounds per cache size (each runs every backend once, in turn); rates are "
                 "medians, ratios the median of the rounds' ratios")
      ->capture_default_str()
      ->check(CLI::Range(1, 99));
  bench::add_results_option(app, o.results);
  bench::parse_command_line(app, argc, argv);
  return bench::run_guarded(app, [&] {
    for (const std::string& b : o.backends) check_radiance_cache_backend(b, false);
    return run(o);
  });
}
