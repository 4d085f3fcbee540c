#pragma once
// A render-farm plan: a camera-path sequence split into chunks of frames, each chunk one plain
// `dofcache sequence --request FILE` command, preceded by a warm-cache pass and followed by a
// check that every frame is complete (and, with --temporal, the temporal filter over the path). Each job's request is the plan's resolved sequence request
// with the job's own fields set (frames, cache files, checkpoint, statistics, threads), stored as
// JSON in the work directory: no command line is edited. The plan is written as Slurm batch
// scripts (a job array, one task per chunk) plus the same commands as a plain shell script, so any
// farm manager can run it.
//
// Cache sharing. The warm pass renders keyframes of the whole path (every warm_step-th frame, at
// warm_spp lens samples) with a persistent cache and saves it as a .vdb file. Every chunk starts
// from that file (--cache-in). With `carry` the chunk carries the cache on through its frames
// (--persistent); its frames then depend on the chunk's first frame, and are bit-identical to a
// `dofcache sequence` process run with the chunk's command. Without it every frame starts from the
// warm cache alone, so frames do not depend on the chunking at all.
//
// Resume. Frames are written atomically, and chunks with persistent caches checkpoint after
// every frame, so resubmitting a plan renders only the chunks that still miss frames, each from
// its last checkpoint.
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "dofcache/request/render_request.h"
#include "dofcache/sequence/sequence_request.h"

namespace dofcache::farm {

// Scheduler settings: nothing about the cluster is assumed; empty / 0 leaves the cluster's own
// default.
struct SlurmOptions {
  std::string partition;
  std::string time_limit;  // per task, Slurm's format, e.g. "2:00:00"
  int cpus_per_task = 0;   // also the renderer's --threads (unless the sequence options set it)
  std::string memory;      // per task, e.g. "8G"
  std::string account;
  std::string job_name = "dofcache";
  int max_running = 0;              // at most this many array tasks at once (0: no limit)
  std::vector<std::string> extra;   // further sbatch options, verbatim (e.g. "--qos=low")
};

// Frames one plan may hold (docs/reliability.md): over eleven hours at 24 fps.
constexpr int kMaxFarmFrames = 1'000'000;

struct FarmSettings {
  std::string dofcache;  // the executable, as the compute nodes see it (absolute)
  std::string work_dir;  // plan, scripts, logs, warm cache, checkpoints, stats (absolute)
  std::string run_dir;   // where the commands run: relative paths in them resolve here (absolute)
  // The resolved sequence request (request::resolve), every path in it absolute or relative to
  // run_dir. Must leave the fields the plan sets per job at their defaults (job_owned_fields).
  request::RenderRequest request = request::default_request(request::Kind::Sequence);
  int first = 0, last = 0;  // frame range
  int chunk = 1;            // frames per chunk (array task)
  std::string output;       // frame file pattern, absolute (for verification)
  int width = 0, height = 0;  // frame size (for verification)
  std::string cache = "none";  // "none", "octree" or "vdb": the sequence's cache backend
  bool carry = false;          // the sequence options say --persistent
  bool warm = true;            // run the warm-cache pass (only with a cache)
  int warm_step = 0;           // keyframe step of the warm pass; 0: the chunk size
  int warm_spp = 4;            // lens samples per pixel of the warm pass; 0: the frames'
  SlurmOptions slurm;

  void validate() const;  // throws dofcache::Error
};

// The fields of a sequence request that the plan sets per job, which `request` sets (named as in
// the request's JSON form): frame_step, cache_in, cache_out, checkpoint, restart, stats_json,
// quiet. Empty: none.
std::vector<std::string> job_owned_fields(const request::RenderRequest& request);

struct Chunk {
  int index = 0;
  int first = 0, last = 0;
};

// [first, last] cut into runs of `size` frames (the last may be shorter). Throws on size < 1.
std::vector<Chunk> make_chunks(int first, int last, int size);

class FarmPlan {
 public:
  explicit FarmPlan(FarmSettings settings);  // validates

  const FarmSettings& settings() const { return settings_; }
  const std::vector<Chunk>& chunks() const { return chunks_; }
  bool has_warm_pass() const;

  // Files in the work directory.
  std::string plan_file() const;        // farm.json
  std::string warm_cache_file() const;  // warm-cache.vdb
  std::string script_file(const std::string& job) const;  // <job>.sbatch: warm, render, verify
  std::string commands_file() const;    // commands.sh
  std::string log_dir() const;          // logs/
  std::string checkpoint_file(const Chunk& c) const;
  std::string stats_file(const Chunk& c) const;
  std::string request_file(const std::string& job) const;  // jobs/<job>.json
  std::string chunk_request_file(const Chunk& c) const;

  // The requests the jobs render: the plan's request with each job's own fields.
  request::RenderRequest warm_request() const;
  request::RenderRequest chunk_request(const Chunk& c) const;
  // With --temporal: the filter over every frame of the plan (sequence/temporal_pass.h), run by
  // the verify job once every frame is complete. The other jobs render only.
  bool has_temporal_pass() const;
  request::RenderRequest temporal_request() const;

  // The commands (argument vectors) that the jobs run.
  std::vector<std::string> warm_command() const;
  std::vector<std::string> chunk_command(const Chunk& c) const;
  std::vector<std::string> verify_command() const;
  std::vector<std::string> temporal_command() const;

  // Script texts.
  std::string warm_script() const;
  std::string render_script() const;  // the job array
  std::string verify_script() const;
  std::string commands_script() const;  // every command in order, for one machine or another farm

  // Writes farm.json, the jobs' requests (jobs/), the three .sbatch scripts and commands.sh into
  // the work directory (each atomically) and creates its logs/, checkpoints/ and stats/
  // directories.
  void write() const;
  // Reads <work_dir>/farm.json. Throws dofcache::Error (one line) if missing or not a plan.
  static FarmPlan load(const std::string& work_dir);

  nlohmann::json to_json() const;
  static FarmPlan from_json(const nlohmann::json& j);  // throws dofcache::Error

 private:
  std::string sbatch_header(const std::string& job, bool array) const;
  FarmSettings settings_;
  std::vector<Chunk> chunks_;
};

// The settings of a plan for `sequence` (a prepared sequence request): its resolved request, frame
// range, frame size, output, cache and whether it carries the cache; the rest (executable,
// directories, chunking, warm pass, cluster) as `base` gives them.
FarmSettings plan_settings(const sequence::PreparedSequence& sequence, FarmSettings base);

// Writes `plan` into its work directory, which holds one plan: the same plan again is fine;
// another is refused with one line unless `replace`, which first removes its warm cache and
// checkpoints (frames stay).
void write_plan(const FarmPlan& plan, bool replace);

// The plan in words, as `farm plan` prints it: frames and chunks, the warm pass, the files written
// and the next command. Each line ends with a newline.
std::string describe_plan(const FarmPlan& plan);

// Which frames of the plan exist and are complete (sequence::frame_complete), and which not.
struct FrameStatus {
  std::vector<int> complete, missing;
};
FrameStatus check_frames(const FarmPlan& plan);

// Indices of the chunks that contain a missing frame.
std::vector<int> chunks_to_render(const FarmPlan& plan, const FrameStatus& status);

// The chunks' own render times, summed from their statistics files (the farm's cost); chunks
// without a readable file are not counted.
struct ChunkTimes {
  double seconds = 0.0;
  int chunks = 0;  // chunks whose statistics were read
};
ChunkTimes chunk_times(const FarmPlan& plan);

// What `farm verify --json` writes: {"frames", "complete", "missing", "chunks_to_render",
// "chunk_seconds_sum", "chunks_with_stats"}.
nlohmann::json verify_json(const FarmPlan& plan, const FrameStatus& status,
                           const ChunkTimes& times);

// "0-3,7,9-10" for {0,1,2,3,7,9,10} (sorted input); "" for none.
std::string format_ranges(const std::vector<int>& sorted);

// POSIX shell quoting: the word unchanged if it is safe, else in single quotes.
std::string shell_quote(const std::string& word);
std::string shell_join(const std::vector<std::string>& argv);

}  // namespace dofcache::farm
