#pragma once
// Submitting a farm plan to Slurm with sbatch: the warm-cache job (if the warm cache is not there
// yet), the job array of the chunks that still miss frames (afterok on the warm job), and the
// verify job (afterany on the array, so it reports even when tasks fail). The command runner is a
// parameter so the dependency chain is testable without a cluster.
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "dofcache/farm/plan.h"

namespace dofcache::farm {

struct CommandResult {
  int exit_code = 0;  // the process's exit code; 127 if it could not be started
  std::string out, err;
};
using CommandRunner = std::function<CommandResult(const std::vector<std::string>& argv)>;

// Runs argv (PATH lookup for argv[0]) and captures both streams. Never throws for a missing
// program: that is exit code 127 with a message in `err`.
CommandResult run_command(const std::vector<std::string>& argv);

struct SubmitOptions {
  std::string sbatch = "sbatch";  // the program
  bool wait = false;  // block until the verify job ends (sbatch --wait) and report its result
};

struct Submission {
  FrameStatus status;          // before submitting
  std::vector<int> chunks;     // array task indices submitted
  std::optional<std::string> warm_job, render_job, verify_job;  // Slurm job ids
  std::vector<std::vector<std::string>> sbatch_calls;           // as run, in order
  std::optional<int> verify_exit;  // with wait: the verify job's exit code
  bool nothing_to_do() const { return chunks.empty(); }
};

// The submission in words, as `farm submit` prints it: the frames complete and missing, then the
// jobs submitted (nothing more for a dry run or when nothing is missing). Lines end with newlines.
std::string describe_submission(const FarmPlan& plan, const Submission& submission, bool dry_run);

// The sbatch argument vectors for a submission of `chunks` (warm job only if `with_warm`); job
// ids are filled in by submit() as "{warm}" and "{render}" placeholders.
std::vector<std::string> sbatch_warm_args(const FarmPlan& plan, const SubmitOptions& options);
std::vector<std::string> sbatch_render_args(const FarmPlan& plan, const SubmitOptions& options,
                                            const std::vector<int>& chunks,
                                            const std::optional<std::string>& warm_job);
std::vector<std::string> sbatch_verify_args(const FarmPlan& plan, const SubmitOptions& options,
                                            const std::string& render_job);

// True if the plan's warm cache file exists and reads back as a dofcache cache file.
bool warm_cache_ready(const FarmPlan& plan);

// Submits what is missing. Throws dofcache::Error (one line) if sbatch fails or prints no job id.
Submission submit(const FarmPlan& plan, const SubmitOptions& options,
                  const CommandRunner& runner = run_command);

// The job id in `sbatch --parsable` output ("123" or "123;cluster"). Throws if there is none.
std::string parse_job_id(const std::string& sbatch_output);

}  // namespace dofcache::farm
