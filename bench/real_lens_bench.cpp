// What a real lens's camera ray costs against its thin-lens equivalent's (lens-prescription issue:
// at most 3x through a 6-10 element lens): rays generated over a 320x240 film on the 36 x 24 mm
// sensor, one thread, for each shipped prescription wide open and at f/8, focused at 3 m. Also
// how many of the traced rays the lens passes (the exit pupil's bounds waste the rest) and the
// cost per ray that brings light. The real lens's rays are generated one by one and, as the
// renderer generates a pixel's, in blocks of 16 traced four at a time (RealLens::sample_n; the
// same rays bit for bit, which the checksums confirm). Lenses are measured in interleaved rounds,
// each keeping its fastest (a shared machine only adds time to a loop this short). Prints a table
// and writes bench/results/real_lens.{json,csv}.
//   real_lens_bench [--rays N] [--rounds N] [--results NAME]
#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "bench_common.h"
#include "dofcache/core/error.h"
#include "dofcache/lens/real_lens.h"
#include "dofcache/render/camera.h"

using namespace dofcache;

namespace {

struct Options {
  int width = 320, threads = 1, rounds = 7;
  int rays = 2'000'000;
  std::string results = "real_lens";
};

struct Case {
  std::string name;
  render::ThinLensCamera real, thin;
  int elements = 0;
};

int run(const Options& o) {
  const int width = o.width, height = o.width * 3 / 4;
  std::vector<Case> cases;
  for (const char* name : {"double_gauss_50mm", "wide_28mm", "telephoto_250mm", "fisheye_10mm"})
    for (double fstop : {0.0, 8.0}) {
      const std::string path = bench::scene_path("lenses/" + std::string(name) + ".lens");
      const lens::MountedLens m = lens::mount_lens(lens::read_lens_file(path), path, fstop, 3.0,
                                                   lens::Sensor{}, width, height, false);
      const lens::ThinLens equivalent = m.equivalent();
      int elements = 0;
      for (const lens::LensSurface& s : m.lens->surfaces()) elements += s.ior != 1.0;
      char label[96];
      std::snprintf(label, sizeof label, "%s f/%.3g", name, m.lens->fstop());
      cases.push_back({label,
                       render::ThinLensCamera(glm::mat4(1.0f), 0.5f, equivalent, width, height, m),
                       render::ThinLensCamera(glm::mat4(1.0f), static_cast<float>(m.yfov()),
                                              equivalent, width, height),
                       elements});
    }
  const std::size_t count = cases.size();
  std::vector<double> real_s(count, 1e30), batched_s(count, 1e30), thin_s(count, 1e30);
  std::vector<double> pass(count);
  float sink = 0.0f;
  for (int round = 0; round < o.rounds; ++round)
    for (std::size_t k = 0; k < count; ++k) {
      float one_by_one = 0.0f, together = 0.0f;
      const bench::RayTiming real =
          bench::time_camera_rays(cases[k].real, o.rays, false, &one_by_one);
      real_s[k] = std::min(real_s[k], real.seconds);
      pass[k] = real.passed;
      batched_s[k] = std::min(
          batched_s[k],
          bench::time_camera_rays_batched(cases[k].real, o.rays, false, &together).seconds);
      // The batch's rays are the scalar's bit for bit, so their sums are too.
      if (one_by_one != together)
        throw Error(cases[k].name + ": the batched rays' checksum differs from the scalar's");
      sink += one_by_one + together;
      thin_s[k] =
          std::min(thin_s[k], bench::time_camera_rays(cases[k].thin, o.rays, false, &sink).seconds);
    }
  bench::Table table({"lens", "elements", "thin [ns/ray]", "real [ns/ray]", "real / thin",
                      "real batched [ns/ray]", "batched / thin", "rays passed",
                      "real per passed ray / thin"});
  for (std::size_t k = 0; k < count; ++k) {
    const double t = thin_s[k] / o.rays * 1e9, r = real_s[k] / o.rays * 1e9;
    const double b = batched_s[k] / o.rays * 1e9;
    table.add_row({cases[k].name, bench::Table::Cell(cases[k].elements),
                   bench::Table::Cell(t, 2), bench::Table::Cell(r, 2),
                   bench::Table::Cell(r / t, 3), bench::Table::Cell(b, 2),
                   bench::Table::Cell(b / t, 3), bench::Table::Cell(pass[k], 3),
                   bench::Table::Cell(r / pass[k] / t, 3)});
  }
  std::printf("Camera rays through the shipped lenses and their thin-lens equivalents, %dx%d on "
              "36 x 24 mm, focused at 3 m; %d rays, one thread, fastest of %d interleaved rounds "
              "(checksum %g)\n",
              width, height, o.rays, o.rounds, static_cast<double>(sink));
  table.print();
  nlohmann::json results;
  results["width"] = width, results["height"] = height;
  results["rays"] = o.rays, results["rounds"] = o.rounds;
  bench::write_table(o.results, table, results);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{"What a real lens's camera ray costs against its thin-lens equivalent's.",
               "real_lens_bench"};
  bench::add_common_options(app, o.width, o.threads, o.results);
  bench::add_rays_option(app, o.rays);
  bench::add_count_option(app, "--rounds", o.rounds, "Interleaved rounds (the fastest is kept)");
  bench::parse_command_line(app, argc, argv);
  return bench::run_guarded(app, [&] { return run(o); });
}
