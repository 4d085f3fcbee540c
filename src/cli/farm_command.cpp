#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "commands.h"
#include "dofcache/cache/radiance_cache.h"
#include "dofcache/core/atomic_file.h"
#include "dofcache/core/error.h"
#include "dofcache/farm/plan.h"
#include "dofcache/farm/slurm.h"
#include "sequence_options.h"
#include "dofcache/sequence/sequence_request.h"

namespace dofcache::cli {
namespace {

namespace fs = std::filesystem;

struct FarmOptions {
  // plan
  std::string work_dir;
  int chunk = 8, warm_step = 0, warm_spp = 4;
  bool no_warm = false, force = false;
  farm::SlurmOptions slurm;
  std::string dofcache;
  // submit
  std::string sbatch = "sbatch";
  bool wait = false, dry_run = false;
  // verify
  std::string json;
  CLI::App *plan = nullptr, *submit = nullptr, *verify = nullptr;
};

std::string absolute(const std::string& p) {
  return fs::absolute(p).lexically_normal().string();
}

std::string self_executable() {
  std::error_code ec;
  fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (ec) throw Error("cannot find this executable's path; give it with --dofcache");
  return exe.string();
}

// The sequence options given to `farm plan`, parsed as `dofcache sequence` parses them, and
// resolved as its request.
sequence::PreparedSequence prepare_plan_sequence(std::vector<std::string> args) {
  request::RenderRequest r = request::default_request(request::Kind::Sequence);
  CLI::App app{"sequence"};
  add_sequence_options(&app, r);
  std::reverse(args.begin(), args.end());  // CLI11 takes the vector last argument first
  try {
    app.parse(args);
  } catch (const CLI::ParseError& e) {
    throw Error(std::string("in the sequence options: ") + e.what());
  }
  // Set per job by the plan (farm::job_owned_fields); --frames gives the plan's range.
  for (const char* name : {"--frame-step", "--cache-in", "--cache-out", "--checkpoint",
                           "--restart", "--stats-json", "--quiet"})
    if (app.count(name) > 0)
      throw Error(std::string(name) + " is set by the plan for each job; leave it out of the "
                  "sequence options");
  return sequence::prepare_sequence(r);
}

int run_plan(FarmOptions& f) {
  sequence::PreparedSequence seq = prepare_plan_sequence(f.plan->remaining());
  farm::FarmSettings s;
  s.dofcache = f.dofcache.empty() ? self_executable() : absolute(f.dofcache);
  s.work_dir = absolute(f.work_dir);
  s.run_dir = fs::current_path().string();
  s.chunk = f.chunk;
  s.warm = !f.no_warm;
  s.warm_step = f.warm_step;
  s.warm_spp = f.warm_spp;
  s.slurm = f.slurm;
  const farm::FarmPlan plan(farm::plan_settings(seq, std::move(s)));
  farm::write_plan(plan, f.force);

  std::printf("%s", farm::describe_plan(plan).c_str());
  return 0;
}

int run_submit(const FarmOptions& f) {
  farm::FarmPlan plan = farm::FarmPlan::load(absolute(f.work_dir));
  farm::SubmitOptions opts;
  opts.sbatch = f.sbatch;
  opts.wait = f.wait;
  farm::CommandRunner runner = farm::run_command;
  int fake_id = 1;  // a dry run numbers its jobs 1, 2, 3
  if (f.dry_run)
    runner = [&](const std::vector<std::string>& argv) {
      std::printf("would run  %s\n", farm::shell_join(argv).c_str());
      return farm::CommandResult{0, std::to_string(fake_id++) + "\n", ""};
    };
  if (f.wait && !f.dry_run)
    std::printf("submit   --wait: once submitted, waits until the verify job has finished\n");
  std::fflush(stdout);
  farm::Submission sub = farm::submit(plan, opts, runner);
  std::printf("%s", farm::describe_submission(plan, sub, f.dry_run).c_str());
  if (sub.nothing_to_do() || f.dry_run) return 0;
  if (!sub.verify_exit) return 0;
  if (*sub.verify_exit != 0)
    throw Error("the farm run left frames missing; see " + plan.log_dir() + "/verify-" +
                *sub.verify_job + ".log");
  std::printf("done     every frame is complete\n");
  return 0;
}

int run_verify(const FarmOptions& f) {
  farm::FarmPlan plan = farm::FarmPlan::load(absolute(f.work_dir));
  farm::FrameStatus st = farm::check_frames(plan);
  const farm::ChunkTimes times = farm::chunk_times(plan);
  const std::vector<int> chunks = farm::chunks_to_render(plan, st);
  if (!f.json.empty()) write_bytes_atomically(f.json, farm::verify_json(plan, st, times).dump(2) + "\n");
  std::size_t total = st.complete.size() + st.missing.size();
  std::printf("verify   %zu of %zu frames complete (%d-%d)", st.complete.size(), total,
              plan.settings().first, plan.settings().last);
  if (times.chunks > 0)
    std::printf("; chunks' own time %.2f s over %d chunks", times.seconds, times.chunks);
  std::printf("\n");
  if (!st.missing.empty())
    throw Error(std::to_string(st.missing.size()) + " of " + std::to_string(total) +
                " frames missing or incomplete: " + farm::format_ranges(st.missing) +
                " (chunks " + farm::format_ranges(chunks) + "); 'dofcache farm submit " +
                plan.settings().work_dir + "' renders them");
  return 0;
}

}  // namespace

Runner add_farm_command(CLI::App& app) {
  auto f = std::make_shared<FarmOptions>();
  CLI::App* farm = app.add_subcommand(
      "farm",
      "Render a camera-path sequence on a Slurm cluster: plan writes batch scripts (a warm-cache "
      "job, a job array of frame chunks, a verify job), submit submits what is missing, verify "
      "checks the frames. See docs/farm.md.");
  farm->require_subcommand(1);

  CLI::App* plan = f->plan = farm->add_subcommand(
      "plan",
      "Write a farm plan. Every option it does not know is a `dofcache sequence` option (scene, "
      "--frames, --out, size, spp, lens, --cache, --persistent, ...), passed to each job; e.g. "
      "dofcache farm plan scene.gltf --frames 0-95 --chunk 8 --out /shared/f/####.exr --cache "
      "vdb --persistent --work-dir /shared/farm --partition render --cpus-per-task 16");
  plan->allow_extras();
  plan->add_option("-w,--work-dir", f->work_dir,
                   "Directory for the plan, scripts, logs, warm cache and checkpoints (on a "
                   "filesystem every node sees)")
      ->required();
  plan->add_option("--chunk", f->chunk, "Frames per array task")->capture_default_str()
      ->check(CLI::Range(1, 1 << 30));
  plan->add_option("--warm-step", f->warm_step,
                   "Warm-cache pass: render every Nth frame of the path (0: one per chunk)")
      ->capture_default_str()->check(CLI::Range(0, 1 << 30));
  plan->add_option("--warm-spp", f->warm_spp,
                   "Lens samples per pixel of the warm-cache pass (0: the frames' own)")
      ->capture_default_str()->check(CLI::Range(0, 1 << 20));
  plan->add_flag("--no-warm", f->no_warm, "No warm-cache job: every chunk starts with an empty "
                                          "cache");
  plan->add_option("--partition", f->slurm.partition, "Slurm partition (default: the cluster's)");
  plan->add_option("--time", f->slurm.time_limit, "Time limit per job, e.g. 2:00:00");
  plan->add_option("--cpus-per-task", f->slurm.cpus_per_task,
                   "CPUs per job, also the renderer's --threads (0: the cluster's default)")
      ->check(CLI::Range(0, 4096));
  plan->add_option("--mem", f->slurm.memory, "Memory per job, e.g. 8G");
  plan->add_option("--account", f->slurm.account, "Slurm account to charge");
  plan->add_option("--job-name", f->slurm.job_name, "Prefix of the job names")
      ->capture_default_str();
  plan->add_option("--max-running", f->slurm.max_running,
                   "At most this many array tasks at once (0: no limit)")
      ->check(CLI::Range(0, 1 << 20));
  plan->add_option("--sbatch-option", f->slurm.extra,
                   "Further sbatch option for every job, written with '=', e.g. "
                   "--sbatch-option=--qos=low (repeatable)")
      ->allow_extra_args(false);
  plan->add_option("--dofcache", f->dofcache,
                   "The dofcache executable as the nodes see it (default: this one)");
  plan->add_flag("--force", f->force,
                 "Replace another plan in the work directory (removes its warm cache and "
                 "checkpoints; frames stay)");

  CLI::App* submit = f->submit = farm->add_subcommand(
      "submit",
      "Submit a plan with sbatch: the warm-cache job (unless its cache is there), the chunks "
      "that miss frames, and the verify job. Prints the job ids. Run it again to render only "
      "what is missing.");
  submit->add_option("WORK_DIR", f->work_dir, "The plan's work directory")->required();
  submit->add_option("--sbatch", f->sbatch, "The sbatch program")->capture_default_str();
  submit->add_flag("--wait", f->wait,
                   "Wait until the verify job has finished; exit non-zero if frames are missing");
  submit->add_flag("--dry-run", f->dry_run, "Print the sbatch commands instead of running them");

  CLI::App* verify = f->verify = farm->add_subcommand(
      "verify",
      "Check that every frame of a plan exists and reads back at the right size; exit non-zero "
      "and list the missing frames otherwise.");
  verify->add_option("WORK_DIR", f->work_dir, "The plan's work directory")->required();
  verify->add_option("--json", f->json, "Also write the result as JSON to this file");

  return [f] {
    if (f->plan->parsed()) return run_plan(*f);
    if (f->submit->parsed()) return run_submit(*f);
    return run_verify(*f);
  };
}

}  // namespace dofcache::cli
