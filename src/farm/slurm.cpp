#include "dofcache/farm/slurm.h"

#include <fcntl.h>
#include <poll.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include <fmt/format.h>

#include "dofcache/core/error.h"
#include "dofcache/sequence/cache_file.h"

extern char** environ;

namespace dofcache::farm {

CommandResult run_command(const std::vector<std::string>& argv) {
  CommandResult r;
  if (argv.empty()) return {127, "", "no command"};
  int out_pipe[2], err_pipe[2];
  if (::pipe2(out_pipe, O_CLOEXEC) != 0) return {127, "", std::strerror(errno)};
  if (::pipe2(err_pipe, O_CLOEXEC) != 0) {
    ::close(out_pipe[0]), ::close(out_pipe[1]);
    return {127, "", std::strerror(errno)};
  }
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, out_pipe[1], STDOUT_FILENO);
  posix_spawn_file_actions_adddup2(&actions, err_pipe[1], STDERR_FILENO);
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  pid_t pid = 0;
  int rc = posix_spawnp(&pid, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  ::close(out_pipe[1]), ::close(err_pipe[1]);
  if (rc != 0) {
    ::close(out_pipe[0]), ::close(err_pipe[0]);
    return {127, "", "cannot run '" + argv[0] + "': " + std::strerror(rc)};
  }
  // Read both streams until both close, without deadlocking on a full pipe.
  pollfd fds[2] = {{out_pipe[0], POLLIN, 0}, {err_pipe[0], POLLIN, 0}};
  std::string* sinks[2] = {&r.out, &r.err};
  int open_streams = 2;
  char buf[4096];
  while (open_streams > 0) {
    if (::poll(fds, 2, -1) < 0) {
      if (errno == EINTR) continue;
      break;
    }
    for (int k = 0; k < 2; ++k) {
      if (fds[k].fd < 0 || !(fds[k].revents & (POLLIN | POLLHUP | POLLERR))) continue;
      ssize_t n = ::read(fds[k].fd, buf, sizeof buf);
      if (n > 0) {
        sinks[k]->append(buf, static_cast<std::size_t>(n));
      } else if (n == 0 || errno != EINTR) {
        ::close(fds[k].fd);
        fds[k].fd = -1;
        --open_streams;
      }
    }
  }
  for (pollfd& f : fds)
    if (f.fd >= 0) ::close(f.fd);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  return r;
}

std::string parse_job_id(const std::string& sbatch_output) {
  std::string s = sbatch_output.substr(0, sbatch_output.find_first_of(";\n"));
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.pop_back();
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.erase(0, 1);
  if (s.empty() || s.find_first_not_of("0123456789") != std::string::npos)
    throw Error("sbatch printed no job id (output: '" + one_line(sbatch_output) + "')");
  return s;
}

std::vector<std::string> sbatch_warm_args(const FarmPlan& plan, const SubmitOptions& options) {
  return {options.sbatch, "--parsable", plan.script_file("warm")};
}

std::vector<std::string> sbatch_render_args(const FarmPlan& plan, const SubmitOptions& options,
                                            const std::vector<int>& chunks,
                                            const std::optional<std::string>& warm_job) {
  std::string array = "--array=" + format_ranges(chunks);
  if (plan.settings().slurm.max_running > 0)
    array += "%" + std::to_string(plan.settings().slurm.max_running);
  std::vector<std::string> argv = {options.sbatch, "--parsable", array};
  if (warm_job) argv.push_back("--dependency=afterok:" + *warm_job);
  argv.push_back(plan.script_file("render"));
  return argv;
}

std::vector<std::string> sbatch_verify_args(const FarmPlan& plan, const SubmitOptions& options,
                                            const std::string& render_job) {
  std::vector<std::string> argv = {options.sbatch, "--parsable",
                                   "--dependency=afterany:" + render_job};
  if (options.wait) argv.push_back("--wait");
  argv.push_back(plan.script_file("verify"));
  return argv;
}

bool warm_cache_ready(const FarmPlan& plan) {
  try {
    sequence::read_cache_file(plan.warm_cache_file());
    return true;
  } catch (const Error&) {
    return false;
  }
}

Submission submit(const FarmPlan& plan, const SubmitOptions& options,
                  const CommandRunner& runner) {
  Submission sub;
  sub.status = check_frames(plan);
  sub.chunks = chunks_to_render(plan, sub.status);
  if (sub.chunks.empty()) return sub;

  auto sbatch = [&](const std::vector<std::string>& argv, bool waits) {
    sub.sbatch_calls.push_back(argv);
    CommandResult r = runner(argv);
    // With --wait, sbatch exits with the job's exit code once it has printed the id.
    if (r.exit_code == 127 && r.out.empty())
      throw Error("sbatch failed: " + one_line(r.err) +
                  " (is Slurm's client installed here? --sbatch names the program; without "
                  "Slurm, " + plan.commands_file() + " runs the same jobs in order)");
    if (r.exit_code != 0 && !(waits && !r.out.empty()))
      throw Error("sbatch failed (exit " + std::to_string(r.exit_code) + "): " +
                  one_line(r.err.empty() ? r.out : r.err));
    return std::make_pair(parse_job_id(r.out), r.exit_code);
  };
  if (plan.has_warm_pass() && !warm_cache_ready(plan))
    sub.warm_job = sbatch(sbatch_warm_args(plan, options), false).first;
  sub.render_job = sbatch(sbatch_render_args(plan, options, sub.chunks, sub.warm_job), false).first;
  auto [verify_id, verify_exit] =
      sbatch(sbatch_verify_args(plan, options, *sub.render_job), options.wait);
  sub.verify_job = verify_id;
  if (options.wait) sub.verify_exit = verify_exit;
  return sub;
}

std::string describe_submission(const FarmPlan& plan, const Submission& sub, bool dry_run) {
  const FrameStatus& st = sub.status;
  std::string text = fmt::format("frames   {} of {} complete", st.complete.size(),
                                 st.complete.size() + st.missing.size());
  if (!st.missing.empty()) text += ", missing " + format_ranges(st.missing);
  text += "\n";
  if (sub.nothing_to_do()) return text + "submit   nothing to do: every frame is complete\n";
  if (dry_run) return text;
  if (sub.warm_job) text += "submit   warm-cache job " + *sub.warm_job + "\n";
  text += fmt::format("submit   render job array {}, tasks {}{}\n", *sub.render_job,
                      format_ranges(sub.chunks),
                      sub.warm_job ? " (after " + *sub.warm_job + ")" : std::string());
  text += fmt::format("submit   verify job {} (after {})\n", *sub.verify_job, *sub.render_job);
  return text + "logs     " + plan.log_dir() + "\n";
}

}  // namespace dofcache::farm
