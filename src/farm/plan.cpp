#include "dofcache/farm/plan.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "dofcache/cache/radiance_cache.h"
#include "dofcache/core/atomic_file.h"
#include "dofcache/core/error.h"
#include "dofcache/sequence/sequence_renderer.h"

namespace dofcache::farm {
namespace {

namespace fs = std::filesystem;
constexpr int kPlanVersion = 2;  // 2: the sequence as a request, not a command line

// "chunk-007.vdb": the index zero-padded to 3 digits, or as many as the last chunk's needs.
std::string chunk_file_name(int index, int count, const char* ext) {
  int digits = std::max(3, static_cast<int>(std::to_string(std::max(count - 1, 0)).size()));
  return fmt::format("chunk-{:0{}d}{}", index, digits, ext);
}

}  // namespace

std::vector<std::string> job_owned_fields(const request::RenderRequest& r) {
  const request::SequenceChoices& q = r.sequence;
  const request::SequenceChoices defaults;
  std::vector<std::string> set;
  if (q.frame_step != defaults.frame_step) set.push_back("frame_step");
  if (!q.cache_in.empty()) set.push_back("cache_in");
  if (!q.cache_out.empty()) set.push_back("cache_out");
  if (!q.checkpoint.empty()) set.push_back("checkpoint");
  if (q.restart) set.push_back("restart");
  if (!r.stats_json.empty()) set.push_back("stats_json");
  if (r.quiet) set.push_back("quiet");
  return set;
}

void FarmSettings::validate() const {
  auto absolute = [](const std::string& what, const std::string& p) {
    if (p.empty() || !fs::path(p).is_absolute())
      throw Error("farm plan: " + what + " must be an absolute path, got '" + p + "'");
  };
  absolute("the dofcache executable", dofcache);
  absolute("the work directory", work_dir);
  absolute("the run directory", run_dir);
  absolute("the output pattern", output);
  sequence::frame_path(output, first);  // a pattern with one run of '#'
  if (first < 0 || last < first)
    throw Error(fmt::format("farm plan: frame range {}-{} is empty or negative", first, last));
  // Every frame may become a chunk, and every chunk a line in each script.
  if (static_cast<long long>(last) - first >= kMaxFarmFrames)
    throw Error(fmt::format("farm plan: frame range {}-{} has more than {} frames", first, last,
                            kMaxFarmFrames));
  if (chunk < 1) throw Error(fmt::format("farm plan: --chunk must be >= 1, got {}", chunk));
  if (width < 1 || height < 1)
    throw Error(fmt::format("farm plan: frame size {}x{} is invalid", width, height));
  try {
    cache::check_radiance_cache_backend(cache, /*allow_none=*/true);
  } catch (const Error& e) {
    throw Error(std::string("farm plan: ") + e.what());
  }
  if (carry && cache == cache::kNoCache) throw Error("farm plan: --persistent needs a cache");
  if (warm_step < 0) throw Error("farm plan: --warm-step must be >= 0");
  if (warm_spp < 0) throw Error("farm plan: --warm-spp must be >= 0");
  if (slurm.cpus_per_task < 0) throw Error("farm plan: --cpus-per-task must be >= 0");
  if (slurm.max_running < 0) throw Error("farm plan: --max-running must be >= 0");
  if (slurm.job_name.empty() ||
      slurm.job_name.find_first_of(" \t\n'\"\\$`") != std::string::npos)
    throw Error("farm plan: job name '" + slurm.job_name + "' must be one plain word");
  if (request.kind != request::Kind::Sequence)
    throw Error("farm plan: the request must be a sequence's");
  if (request.sequence.temporal_only)
    throw Error("farm plan: the plan runs the temporal filter itself (drop --temporal-only)");
  for (const std::string& f : job_owned_fields(request))
    throw Error("farm plan: the sequence request must not set " + f + " (the plan sets it per job)");
  for (const std::string& e : slurm.extra)
    if (e.rfind("-", 0) != 0 || e.find('\n') != std::string::npos)
      throw Error("farm plan: sbatch option '" + e + "' must be one option starting with '-'");
}

std::vector<Chunk> make_chunks(int first, int last, int size) {
  if (size < 1) throw Error(fmt::format("chunk size must be >= 1, got {}", size));
  if (last < first) throw Error(fmt::format("frame range {}-{} is empty", first, last));
  std::vector<Chunk> chunks;
  for (long long a = first; a <= last; a += size)
    chunks.push_back({static_cast<int>(chunks.size()), static_cast<int>(a),
                      static_cast<int>(std::min<long long>(last, a + size - 1))});
  return chunks;
}

FarmPlan::FarmPlan(FarmSettings settings) : settings_(std::move(settings)) {
  settings_.validate();
  chunks_ = make_chunks(settings_.first, settings_.last, settings_.chunk);
}

bool FarmPlan::has_warm_pass() const { return settings_.warm && settings_.cache != cache::kNoCache; }

std::string FarmPlan::plan_file() const { return (fs::path(settings_.work_dir) / "farm.json").string(); }
std::string FarmPlan::warm_cache_file() const {
  return (fs::path(settings_.work_dir) / "warm-cache.vdb").string();
}
std::string FarmPlan::script_file(const std::string& job) const {
  return (fs::path(settings_.work_dir) / (job + ".sbatch")).string();
}
std::string FarmPlan::commands_file() const {
  return (fs::path(settings_.work_dir) / "commands.sh").string();
}
std::string FarmPlan::log_dir() const { return (fs::path(settings_.work_dir) / "logs").string(); }
std::string FarmPlan::checkpoint_file(const Chunk& c) const {
  const int n = static_cast<int>(chunks_.size());
  return (fs::path(settings_.work_dir) / "checkpoints" / chunk_file_name(c.index, n, ".vdb"))
      .string();
}
std::string FarmPlan::stats_file(const Chunk& c) const {
  const int n = static_cast<int>(chunks_.size());
  return (fs::path(settings_.work_dir) / "stats" / chunk_file_name(c.index, n, ".json")).string();
}

std::string FarmPlan::request_file(const std::string& job) const {
  return (fs::path(settings_.work_dir) / "jobs" / (job + ".json")).string();
}
std::string FarmPlan::chunk_request_file(const Chunk& c) const {
  const int n = static_cast<int>(chunks_.size());
  return (fs::path(settings_.work_dir) / "jobs" / chunk_file_name(c.index, n, ".json")).string();
}

namespace {

// The plan's request with what every job sets: the cluster's CPUs as threads (unless the request
// names a count), and the job's statistics file.
// The warm pass and the chunks render only: the temporal filter needs frames of other chunks, so
// the last job runs it over the whole path (temporal_request).
request::RenderRequest job_request(const FarmSettings& s, std::string stats) {
  request::RenderRequest r = s.request;
  if (s.slurm.cpus_per_task > 0 && r.threads == 0) r.threads = s.slurm.cpus_per_task;
  r.stats_json = std::move(stats);
  r.sequence.temporal = 0;
  r.sequence.temporal_output.clear();
  return r;
}

}  // namespace

request::RenderRequest FarmPlan::warm_request() const {
  const FarmSettings& s = settings_;
  const fs::path work(s.work_dir);
  request::RenderRequest r = job_request(s, (work / "stats" / "warm.json").string());
  r.out = (work / "warm" / "####.png").string();
  if (s.warm_spp > 0) r.spp = s.warm_spp;
  r.sequence.persistent = true;
  r.sequence.frames = fmt::format("{}-{}", s.first, s.last);
  r.sequence.frame_step = s.warm_step > 0 ? s.warm_step : s.chunk;
  r.sequence.cache_out = warm_cache_file();
  return r;
}

request::RenderRequest FarmPlan::chunk_request(const Chunk& c) const {
  request::RenderRequest r = job_request(settings_, stats_file(c));
  r.sequence.frames = fmt::format("{}-{}", c.first, c.last);
  if (has_warm_pass()) {
    r.sequence.cache_in = warm_cache_file();
    // The warm pass rendered this path, whose lens may change between its frames.
    r.sequence.cache_any_lens = true;
  }
  if (settings_.carry) r.sequence.checkpoint = checkpoint_file(c);
  return r;
}

bool FarmPlan::has_temporal_pass() const { return settings_.request.sequence.temporal > 0; }

request::RenderRequest FarmPlan::temporal_request() const {
  const FarmSettings& s = settings_;
  request::RenderRequest r = s.request;
  if (s.slurm.cpus_per_task > 0 && r.threads == 0) r.threads = s.slurm.cpus_per_task;
  r.stats_json = (fs::path(s.work_dir) / "stats" / "temporal.json").string();
  r.sequence.frames = fmt::format("{}-{}", s.first, s.last);
  r.sequence.temporal_only = true;
  return r;
}

std::vector<std::string> FarmPlan::temporal_command() const {
  return {settings_.dofcache, "sequence", "--request", request_file("temporal")};
}

std::vector<std::string> FarmPlan::warm_command() const {
  return {settings_.dofcache, "sequence", "--request", request_file("warm")};
}

std::vector<std::string> FarmPlan::chunk_command(const Chunk& c) const {
  return {settings_.dofcache, "sequence", "--request", chunk_request_file(c)};
}

std::vector<std::string> FarmPlan::verify_command() const {
  return {settings_.dofcache, "farm", "verify", settings_.work_dir};
}

std::string FarmPlan::sbatch_header(const std::string& job, bool array) const {
  const SlurmOptions& o = settings_.slurm;
  std::ostringstream h;
  h << "#!/bin/bash\n";
  h << "#SBATCH --job-name=" << o.job_name << "-" << job << "\n";
  if (array) {
    h << "#SBATCH --array=0-" << chunks_.size() - 1;
    if (o.max_running > 0) h << "%" << o.max_running;
    h << "\n";
  }
  std::string log = (fs::path(log_dir()) / (array ? job + "-%A_%a.log" : job + "-%j.log")).string();
  h << "#SBATCH --output=" << log << "\n";
  h << "#SBATCH --chdir=" << settings_.run_dir << "\n";
  if (!o.partition.empty()) h << "#SBATCH --partition=" << o.partition << "\n";
  if (!o.time_limit.empty()) h << "#SBATCH --time=" << o.time_limit << "\n";
  if (!o.account.empty()) h << "#SBATCH --account=" << o.account << "\n";
  if (!o.memory.empty()) h << "#SBATCH --mem=" << o.memory << "\n";
  if (o.cpus_per_task > 0) h << "#SBATCH --cpus-per-task=" << o.cpus_per_task << "\n";
  h << "#SBATCH --ntasks=1\n";
  // A task whose dependency can never be met (the warm job failed) is cancelled, not left
  // pending forever; the verify job then reports the missing frames.
  if (job != "verify") h << "#SBATCH --kill-on-invalid-dep=yes\n";
  for (const std::string& e : o.extra) h << "#SBATCH " << e << "\n";
  h << "set -euo pipefail\n";
  return h.str();
}

std::string FarmPlan::warm_script() const {
  return sbatch_header("warm", false) +
         "# Warm cache: keyframes of the whole path, the cache saved for every chunk.\n"
         "exec " + shell_join(warm_command()) + "\n";
}

std::string FarmPlan::render_script() const {
  std::ostringstream s;
  s << sbatch_header("render", true);
  s << "# One array task per chunk of frames; each is a plain `dofcache sequence` call.\n";
  s << "case \"${SLURM_ARRAY_TASK_ID:?run this script as a Slurm job array}\" in\n";
  for (const Chunk& c : chunks_)
    s << "  " << c.index << ")  # frames " << c.first << "-" << c.last << "\n    exec "
      << shell_join(chunk_command(c)) << " ;;\n";
  s << "  *) echo \"no chunk $SLURM_ARRAY_TASK_ID in this plan\" >&2; exit 2 ;;\n";
  s << "esac\n";
  return s.str();
}

std::string FarmPlan::verify_script() const {
  std::string s = sbatch_header("verify", false) +
                  "# Checks that every frame exists and reads back; lists the missing ones.\n";
  if (!has_temporal_pass()) return s + "exec " + shell_join(verify_command()) + "\n";
  return s + shell_join(verify_command()) + "\n" +
         "# Then the temporal filter over the whole path, which reads every chunk's frames.\n"
         "exec " + shell_join(temporal_command()) + "\n";
}

std::string FarmPlan::commands_script() const {
  std::ostringstream s;
  s << "#!/bin/bash\n"
       "# The farm plan's commands in order, for one machine or another farm manager: the warm\n"
       "# pass first, then the chunks (independent of each other), then the check.\n"
       "set -euo pipefail\n";
  s << "cd " << shell_quote(settings_.run_dir) << "\n";
  if (has_warm_pass()) s << shell_join(warm_command()) << "\n";
  for (const Chunk& c : chunks_) s << shell_join(chunk_command(c)) << "\n";
  s << shell_join(verify_command()) << "\n";
  if (has_temporal_pass()) s << shell_join(temporal_command()) << "\n";
  return s.str();
}

void FarmPlan::write() const {
  const fs::path work(settings_.work_dir);
  std::error_code ec;
  for (const char* sub : {"logs", "checkpoints", "stats", "warm", "jobs"}) {
    fs::create_directories(work / sub, ec);
    if (ec) throw Error("cannot create '" + (work / sub).string() + "': " + ec.message());
  }
  if (has_warm_pass())
    write_bytes_atomically(request_file("warm"), request::to_json(warm_request()).dump(2) + "\n");
  for (const Chunk& c : chunks_)
    write_bytes_atomically(chunk_request_file(c),
                           request::to_json(chunk_request(c)).dump(2) + "\n");
  if (has_temporal_pass())
    write_bytes_atomically(request_file("temporal"),
                           request::to_json(temporal_request()).dump(2) + "\n");
  write_bytes_atomically(script_file("warm"), warm_script(), FileMode::Executable);
  write_bytes_atomically(script_file("render"), render_script(), FileMode::Executable);
  write_bytes_atomically(script_file("verify"), verify_script(), FileMode::Executable);
  write_bytes_atomically(commands_file(), commands_script(), FileMode::Executable);
  write_bytes_atomically(plan_file(), to_json().dump(2) + "\n");  // last: a plan is complete
}

nlohmann::json FarmPlan::to_json() const {
  const FarmSettings& s = settings_;
  const SlurmOptions& o = s.slurm;
  nlohmann::json chunks = nlohmann::json::array();
  for (const Chunk& c : chunks_) chunks.push_back({c.first, c.last});
  return {{"dofcache_farm_plan", kPlanVersion},
          {"dofcache", s.dofcache},
          {"work_dir", s.work_dir},
          {"run_dir", s.run_dir},
          {"request", request::to_json(s.request)},
          {"frames", {s.first, s.last}},
          {"chunk", s.chunk},
          {"output", s.output},
          {"size", {s.width, s.height}},
          {"cache", s.cache},
          {"carry", s.carry},
          {"warm", {{"enabled", s.warm}, {"step", s.warm_step}, {"spp", s.warm_spp}}},
          {"slurm",
           {{"partition", o.partition},
            {"time", o.time_limit},
            {"cpus_per_task", o.cpus_per_task},
            {"mem", o.memory},
            {"account", o.account},
            {"job_name", o.job_name},
            {"max_running", o.max_running},
            {"extra", o.extra}}},
          {"chunks", chunks}};
}

FarmPlan FarmPlan::from_json(const nlohmann::json& j) {
  try {
    if (!j.is_object() || j.value("dofcache_farm_plan", 0) != kPlanVersion)
      throw Error("not a dofcache farm plan of version " + std::to_string(kPlanVersion));
    FarmSettings s;
    s.dofcache = j.at("dofcache").get<std::string>();
    s.work_dir = j.at("work_dir").get<std::string>();
    s.run_dir = j.at("run_dir").get<std::string>();
    s.request = request::request_from_json(j.at("request"));
    s.first = j.at("frames").at(0).get<int>();
    s.last = j.at("frames").at(1).get<int>();
    s.chunk = j.at("chunk").get<int>();
    s.output = j.at("output").get<std::string>();
    s.width = j.at("size").at(0).get<int>();
    s.height = j.at("size").at(1).get<int>();
    s.cache = j.at("cache").get<std::string>();
    s.carry = j.at("carry").get<bool>();
    const nlohmann::json& w = j.at("warm");
    s.warm = w.at("enabled").get<bool>();
    s.warm_step = w.at("step").get<int>();
    s.warm_spp = w.at("spp").get<int>();
    const nlohmann::json& o = j.at("slurm");
    s.slurm.partition = o.at("partition").get<std::string>();
    s.slurm.time_limit = o.at("time").get<std::string>();
    s.slurm.cpus_per_task = o.at("cpus_per_task").get<int>();
    s.slurm.memory = o.at("mem").get<std::string>();
    s.slurm.account = o.at("account").get<std::string>();
    s.slurm.job_name = o.at("job_name").get<std::string>();
    s.slurm.max_running = o.at("max_running").get<int>();
    s.slurm.extra = o.at("extra").get<std::vector<std::string>>();
    return FarmPlan(std::move(s));
  } catch (const nlohmann::json::exception& e) {
    throw Error(std::string("not a valid dofcache farm plan (") + e.what() + ")");
  }
}

FarmPlan FarmPlan::load(const std::string& work_dir) {
  const std::string path = (fs::path(work_dir) / "farm.json").string();
  std::ifstream in(path);
  if (!in) throw Error(path + ": no farm plan here (run 'dofcache farm plan' first)");
  try {
    return from_json(nlohmann::json::parse(in));
  } catch (const nlohmann::json::exception& e) {
    throw Error(path + ": not valid JSON (" + one_line(e.what()) + ")");
  } catch (const Error& e) {
    throw Error(path + ": " + e.what());
  }
}

FarmSettings plan_settings(const sequence::PreparedSequence& seq, FarmSettings s) {
  // Resolved: the warm pass renders fewer lens samples than the frames, but its cache has the
  // frames' sample quality (cache files record it), which the request names.
  s.request = seq.resolved.request;
  s.request.sequence.frames.clear();  // the plan's range, cut into chunks
  s.first = seq.first;
  s.last = seq.last;
  s.output = fs::absolute(seq.resolved.request.out).lexically_normal().string();
  s.width = seq.settings.render.width;
  s.height = seq.settings.render.height;
  s.cache = seq.settings.cache_mode == sequence::CacheMode::None ? cache::kNoCache
                                                                  : seq.settings.cache_backend;
  s.carry = seq.settings.cache_mode == sequence::CacheMode::Persistent;
  return s;
}

void write_plan(const FarmPlan& plan, bool replace) {
  // A work directory holds one plan: another plan's warm cache and checkpoints are not mixed in.
  std::error_code ec;
  if (fs::exists(plan.plan_file(), ec)) {
    bool same = false;
    try {
      same = FarmPlan::load(plan.settings().work_dir).to_json() == plan.to_json();
    } catch (const Error&) {
    }
    if (!same && !replace)
      throw Error(plan.settings().work_dir +
                  " holds another farm plan; use a new --work-dir, or --force to replace it "
                  "(its warm cache and checkpoints are removed)");
    if (!same) {
      fs::remove(plan.warm_cache_file(), ec);
      fs::remove_all(fs::path(plan.settings().work_dir) / "checkpoints", ec);
    }
  }
  plan.write();
}

std::string describe_plan(const FarmPlan& plan) {
  const FarmSettings& s = plan.settings();
  const std::size_t n = plan.chunks().size();
  std::string text = fmt::format(
      "plan     frames {}-{} in {} chunk(s) of up to {} (array tasks 0-{}), {}x{}, cache {}{}\n",
      s.first, s.last, n, s.chunk, n - 1, s.width, s.height, s.cache,
      s.cache == cache::kNoCache ? "" : s.carry ? " carried through each chunk"
                                                : " (fresh per frame)");
  if (plan.has_warm_pass())
    text += fmt::format("warm     keyframes every {} frames at {} spp -> {}\n",
                        s.warm_step > 0 ? s.warm_step : s.chunk,
                        s.warm_spp > 0 ? std::to_string(s.warm_spp) : "full",
                        plan.warm_cache_file());
  return text + fmt::format("frames   {}\nwrote    {}, {}, {}, {}, {}\nnext     dofcache farm "
                            "submit {}\n",
                            s.output, plan.plan_file(), plan.script_file("warm"),
                            plan.script_file("render"), plan.script_file("verify"),
                            plan.commands_file(), shell_quote(s.work_dir));
}

ChunkTimes chunk_times(const FarmPlan& plan) {
  ChunkTimes t;
  for (const Chunk& c : plan.chunks()) {
    std::ifstream in(plan.stats_file(c));
    if (!in) continue;
    try {
      const nlohmann::json j = nlohmann::json::parse(in);
      t.seconds += j.at("seconds").get<double>();
      ++t.chunks;
    } catch (const nlohmann::json::exception&) {
    }
  }
  return t;
}

nlohmann::json verify_json(const FarmPlan& plan, const FrameStatus& st, const ChunkTimes& times) {
  return {{"frames", {plan.settings().first, plan.settings().last}},
          {"complete", st.complete},
          {"missing", st.missing},
          {"chunks_to_render", chunks_to_render(plan, st)},
          {"chunk_seconds_sum", times.seconds},
          {"chunks_with_stats", times.chunks}};
}

FrameStatus check_frames(const FarmPlan& plan) {
  const FarmSettings& s = plan.settings();
  FrameStatus st;
  for (int f = s.first; f <= s.last; ++f)
    (sequence::frame_complete(sequence::frame_path(s.output, f), s.width, s.height) ? st.complete
                                                                                   : st.missing)
        .push_back(f);
  return st;
}

std::vector<int> chunks_to_render(const FarmPlan& plan, const FrameStatus& status) {
  std::vector<int> out;
  for (const Chunk& c : plan.chunks())
    if (std::any_of(status.missing.begin(), status.missing.end(),
                    [&](int f) { return f >= c.first && f <= c.last; }))
      out.push_back(c.index);
  return out;
}

std::string format_ranges(const std::vector<int>& sorted) {
  std::string out;
  for (std::size_t i = 0; i < sorted.size();) {
    std::size_t j = i;
    while (j + 1 < sorted.size() && sorted[j + 1] == sorted[j] + 1) ++j;
    if (!out.empty()) out += ",";
    out += j == i ? std::to_string(sorted[i])
                  : std::to_string(sorted[i]) + "-" + std::to_string(sorted[j]);
    i = j + 1;
  }
  return out;
}

std::string shell_quote(const std::string& word) {
  if (!word.empty() &&
      word.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789"
                             "@%_+=:,./-#") == std::string::npos &&
      word[0] != '#')
    return word;
  std::string q = "'";
  for (char c : word) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

std::string shell_join(const std::vector<std::string>& argv) {
  std::string out;
  for (const std::string& a : argv) out += (out.empty() ? "" : " ") + shell_quote(a);
  return out;
}

}  // namespace dofcache::farm
