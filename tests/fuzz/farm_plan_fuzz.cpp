// Farm plans (<work_dir>/farm.json): the JSON, the settings' validation, the chunks, and the
// scripts a loaded plan writes.
#include "dofcache/farm/plan.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dofcache;
  fuzz::write_input("farm.json", data, size);
  fuzz::expect_clean([&] {
    farm::FarmPlan plan = farm::FarmPlan::load(fuzz::scratch_dir().string());
    if (plan.chunks().size() > 1000) return;  // scripts of a million lines: slow, not new
    plan.render_script();
    plan.commands_script();
  });
  return 0;
}
