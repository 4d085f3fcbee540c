// Writes the binary seed corpora with dofcache's own writers, so the fuzzers start from what
// the program really produces: corpus/cache_file (the OpenVDB part, trailer stripped: the
// target adds it), corpus/preview_inputs, corpus/trace, corpus/farm_plan.
// Usage: fuzz_seeds <corpus directory>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <nlohmann/json.hpp>

#include "dofcache/cache/trace.h"
#include "dofcache/farm/plan.h"
#include "dofcache/preview/inputs_file.h"
#include "dofcache/sequence/cache_file.h"

namespace fs = std::filesystem;
using namespace dofcache;

namespace {

void cache_file_seed(const fs::path& dir, int samples, bool checkpoint) {
  sequence::CacheFile f;
  f.identity = {0x0123456789abcdefULL, 1, 4, 1, 2};
  f.scene_source = "seed.gltf";
  for (int i = 0; i < samples; ++i) {
    cache::SampleRecord r;
    r.sample.position = {0.1f * i, 0.05f * i, -1.0f};
    r.sample.normal = {0.0f, 0.0f, 1.0f};
    r.sample.value = {0.5f, 0.25f, 0.125f};
    r.sample.radius = 0.01f;
    r.sample.id = static_cast<std::uint32_t>(i);
    r.origin = {0.01f, 0.01f, 0.001f};
    f.records.push_back(r);
  }
  if (checkpoint) {  // a checkpoint as a sequence writes it, with the lens recorded
    f.checkpoint = sequence::SequenceCheckpoint{0xfeedULL, 0, 3};
    lens::ApertureShape six;
    six.blades = 6;
    f.lens = lens::lens_identity(lens::ThinLens(0.05, 2.8, 3.0, six));
  }
  fs::path path = dir / ("samples-" + std::to_string(samples) + ".vdb");
  sequence::write_cache_file(path.string(), f);
  fs::resize_file(path, fs::file_size(path) - 24);  // the trailer
}

void preview_inputs_seed(const fs::path& dir) {
  const int w = 8, h = 6;
  preview::PreviewInputs in;
  in.color = image::Image(w, h, 3, 0.5f);
  in.depth = image::Image(w, h, 1, 2.0f);
  in.ids = image::Image(w, h, 1, 1.0f);
  in.imaging.lens = {0.05, 2.8, 2.0};
  in.imaging.y_resolution = h;
  preview::RevealedLayer r;
  r.near_depth = 1.5;
  r.color = image::Image(w, h, 3, 0.25f);
  r.depth = image::Image(w, h, 1, 3.0f);
  r.mask = image::Image(w, h, 1, 0.0f);
  for (int x = 2; x < 5; ++x) r.mask.at(x, 3, 0) = 1.0f;
  in.revealed.push_back(r);
  preview::RevealedCoverage c{true, 1.5, 4.0, 0.05 / 2.8};
  preview::save_preview_inputs((dir / "inputs.exr").string(), in, c);
  // A lens that is not plain: its aperture's attributes, a real lens's rims among them.
  in.revealed.clear();
  in.imaging.lens.aperture.blades = 6;
  in.imaging.lens.aperture.rims = {{0.012, 0.018}, {0.009, 0.014}, true};
  preview::save_preview_inputs((dir / "inputs_shaped.exr").string(), in, {});
}

void trace_seed(const fs::path& dir) {
  cache::CacheTrace t;
  for (int p = 0; p < 2; ++p) {
    cache::TracePass pass;
    pass.lookups.push_back({{0.0f, 1.0f, 2.0f}, {0.0f, 0.0f, 1.0f}});
    cache::CacheSample s;
    s.position = {0.5f, 0.5f, 0.5f};
    s.value = {1.0f, 1.0f, 1.0f};
    s.radius = 0.1f;
    s.frame = static_cast<std::uint32_t>(p);
    pass.inserts.push_back(s);
    t.passes.push_back(pass);
  }
  cache::write_trace((dir / "two-passes.bin").string(), t);
}

void farm_plan_seed(const fs::path& dir) {
  farm::FarmSettings s;
  s.dofcache = "/opt/dofcache/bin/dofcache";
  s.work_dir = "/farm/work";
  s.run_dir = "/farm";
  s.request.scene = "scene.gltf";
  s.request.width = 64;
  s.request.cache = "vdb";
  s.request.sequence.persistent = true;
  s.first = 10;
  s.last = 15;
  s.chunk = 4;
  s.output = "/farm/f/####.exr";
  s.width = 64;
  s.height = 48;
  s.cache = "vdb";
  s.carry = true;
  s.slurm.partition = "render";
  s.slurm.extra = {"--qos=low"};
  std::ofstream(dir / "farm.json") << farm::FarmPlan(s).to_json().dump(2) << "\n";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: fuzz_seeds <corpus directory>\n");
    return 2;
  }
  const fs::path root = argv[1];
  for (const char* sub : {"cache_file", "preview_inputs", "trace", "farm_plan"})
    fs::create_directories(root / sub);
  try {
    cache_file_seed(root / "cache_file", 3, false);
    cache_file_seed(root / "cache_file", 40, true);
    preview_inputs_seed(root / "preview_inputs");
    trace_seed(root / "trace");
    farm_plan_seed(root / "farm_plan");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fuzz_seeds: %s\n", e.what());
    return 1;
  }
  return 0;
}
