#include <cstdio>
#include <memory>

#include "commands.h"
#include "dofcache/core/atomic_file.h"
#include "dofcache/image/image_io.h"
#include "dofcache/image/metrics.h"

namespace dofcache::cli {
namespace {

struct CompareOptions {
  std::string test, reference, error_map, json_path;
  bool json = false;
  double error_map_max = 0.1;
};

int run_compare(const CompareOptions& o) {
  image::Image test = image::read_image(o.test);
  image::Image reference = image::read_image(o.reference);
  image::ErrorMetrics m = image::compare(test, reference);
  nlohmann::json j = {{"test", o.test},     {"reference", o.reference}, {"rel_mse", m.rel_mse},
                      {"mse", m.mse},       {"psnr", m.psnr},           {"ssim", m.ssim}};
  if (!o.error_map.empty())
    image::write_image(o.error_map,
                       image::false_color(image::relative_error_map(test, reference), o.error_map_max));
  if (!o.json_path.empty()) write_bytes_atomically(o.json_path, j.dump(2) + "\n");
  if (o.json) {
    std::printf("%s\n", j.dump(2).c_str());
  } else {
    std::printf("relMSE %.6g   MSE %.6g   PSNR %.2f dB   SSIM %.4f\n", m.rel_mse, m.mse, m.psnr,
                m.ssim);
  }
  return 0;
}

}  // namespace

Runner add_compare_command(CLI::App& app) {
  auto o = std::make_shared<CompareOptions>();
  CLI::App* cmd = app.add_subcommand(
      "compare", "Error of an image against a reference: relative MSE, MSE, PSNR and SSIM.");
  cmd->add_option("TEST", o->test, "Image to judge (.exr, .png)")->required();
  cmd->add_option("REFERENCE", o->reference, "Reference image of the same size")->required();
  cmd->add_flag("--json", o->json, "Print the metrics as JSON");
  cmd->add_option("--json-out", o->json_path, "Also write the metrics as JSON to this file");
  cmd->add_option("--error-map", o->error_map,
                  "Write a false-colour map of the per-pixel relative squared error");
  cmd->add_option("--error-map-max", o->error_map_max,
                  "Relative squared error shown as white in the error map")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  return [o] { return run_compare(*o); };
}

}  // namespace dofcache::cli
