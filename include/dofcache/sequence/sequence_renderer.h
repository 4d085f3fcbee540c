#pragma once
// Rendering the frames of a camera path in order, with a radiance cache that is either absent,
// fresh for every frame, or persistent across frames (persistent_cache.h), writing each frame
// atomically and resuming an interrupted run.
//
// Resume. A frame's image is written to a temporary file and renamed, so an output file that
// exists and reads back is a complete frame. Without a persistent cache frames are independent:
// complete frames are skipped. With one, frame f depends on the cache left by frames before it,
// so after every frame the cache is saved as a checkpoint, after the image: a record of what the
// frame changed appended to a journal, or now and then the whole cache (checkpoint_store.h).
// A rerun loads the checkpoint if it matches the run (same scene, settings, first frame and the
// same camera and lens for every frame up to the checkpoint; see sequence_key) and every frame up
// to it is complete, replays the journal's records as far as they continue the run (each
// checked against its frame's key, its image and the cache state it recorded), and continues
// after the last; the frames then come out exactly as in an uninterrupted run. Otherwise it
// starts from the first frame.
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "dofcache/render/renderer.h"
#include "dofcache/scene/accel.h"
#include "dofcache/scene/scene.h"
#include "dofcache/sequence/camera_path.h"
#include "dofcache/sequence/checkpoint_journal.h"
#include "dofcache/cache/persistent_cache.h"

namespace dofcache::sequence {

enum class CacheMode {
  None,        // shade every lens ray
  Fresh,       // a new cache for every frame (starting from --cache-in, if given)
  Persistent,  // one cache carried across the frames
};
const char* cache_mode_name(CacheMode mode);

struct SequenceSettings {
  // The per-frame render: size, spp, mode, seed, shading, threads and the cache settings
  // (render.cache: min_factor, lookup, sample_quality). The cache pointer, frame and seed are set
  // per frame (frame_seed); render.progress is the display of the sequence's one progress bar.
  render::RenderSettings render;
  CacheMode cache_mode = CacheMode::Persistent;
  std::string cache_backend = "vdb";  // "octree" or "vdb" (ignored for CacheMode::None)
  int evict_after = 8;                // frames without use before a sample is evicted (0: never)
  double cache_memory_mb = 0.0;       // cap on the cache's memory in MB (10^6 bytes); 0: none
  // Output file pattern: a run of '#' is replaced by the zero-padded frame number, e.g.
  // "frames/####.exr". Empty: frames are not written (on_frame still gets them).
  std::string output;
  std::string cache_in;   // load this cache file first (refused if made for something else)
  bool cache_any_lens = false;  // accept a cache_in made through a lens of another design
  std::string cache_out;  // save the cache here at the end
  // Checkpoint of a persistent cache; empty: default_checkpoint_path(output) when writing frames,
  // none otherwise.
  std::string checkpoint;
  bool resume = true;  // false: render every frame, ignoring existing frames and checkpoints
  // Frames append to the checkpoint's journal while it stays within this many times the size of
  // the full checkpoint, then one rewrites the full checkpoint (CheckpointStore). 0: the full
  // checkpoint after every frame.
  double checkpoint_journal_ratio = 1.0;
  // The temporal filter over the written frames (temporal_pass.h): frames on each side (0: none)
  // and the pattern of the filtered frames. It needs EXR frames with the denoiser's layers
  // (render.lens_features).
  int temporal_window = 0;
  std::string temporal_output;

  void validate() const;  // throws dofcache::Error
};

struct FrameReport {
  int frame = 0;
  int index = 0, count = 0;  // position in the sequence
  FrameSpec spec;            // its camera and lens (statistics files report them)
  bool skipped = false;      // complete from an earlier run: not rendered (output is empty)
  std::string path;          // output file (empty if not writing)
  render::RenderOutput output;
  // With RenderSettings::lens_features (--denoise): output.color denoised, and the filter's time.
  std::optional<image::Image> denoised;
  double denoise_seconds = 0.0;
  cache::FrameCacheStats cache;      // zero without a cache
  double render_seconds = 0.0;  // the renderer
  double cache_seconds = 0.0;   // cache maintenance (reuse rule, rebuilds, eviction)
  double write_seconds = 0.0;   // image and checkpoint files
  // The checkpoint saved after the frame: bytes written, whether it was a full checkpoint (else
  // a journal record), and its wall and process CPU time (in write_seconds, except for the copy
  // of the cache that a journal record is computed against, made before the render).
  std::uint64_t checkpoint_bytes = 0;
  bool checkpoint_full = false;
  double checkpoint_seconds = 0.0, checkpoint_cpu_seconds = 0.0;
  double seconds() const {
    return render_seconds + denoise_seconds + cache_seconds + write_seconds;
  }
};

struct SequenceSummary {
  int rendered = 0, skipped = 0;
  int resumed_after = -1;  // the checkpoint's frame when a persistent run resumed, else -1
  int journal_records_replayed = 0;  // of those frames, the ones replayed from the journal
  double seconds = 0.0;
  // The cache's reuse rate summed over the frames rendered after the sequence's first (with a
  // cache), and their count.
  double reuse_sum = 0.0;
  int reuse_frames = 0;
};

class SequenceRenderer {
 public:
  using FrameCallback = std::function<void(const FrameReport&)>;
  using NoticeCallback = std::function<void(const std::string&)>;

  // `frames` in increasing frame number (plan_frames). Throws dofcache::Error on invalid
  // settings.
  SequenceRenderer(const scene::Scene& scene, const scene::Accel& accel,
                   std::vector<FrameSpec> frames, SequenceSettings settings);

  // Renders the sequence. on_frame runs after each frame (and its checkpoint) is written, and for
  // each skipped frame; an exception it throws stops the sequence, everything written so far
  // stays complete. notice receives one-line messages (resuming, starting over, ...).
  SequenceSummary run(const FrameCallback& on_frame = {}, const NoticeCallback& notice = {});

  // The persistent (or last fresh) cache, e.g. for inspection after run().
  const cache::PersistentCache* cache() const { return cache_.get(); }
  const std::string& checkpoint_path() const { return checkpoint_; }

 private:
  // Replays `journal` on `records` (the cache after frames_[at], the base's frame) while its
  // records continue this run; returns how many it replayed, and in `why` the reason it stopped
  // before the journal's end (empty: none, or the sequence ended).
  std::size_t replay_journal(const CheckpointJournal& journal, std::size_t at,
                             const std::vector<std::string>& paths, std::uint64_t initial_hash,
                             std::vector<cache::SampleRecord>& records, std::string* why) const;

  const scene::Scene& scene_;
  const scene::Accel& accel_;
  std::vector<FrameSpec> frames_;
  SequenceSettings settings_;
  std::string checkpoint_;
  std::unique_ptr<cache::PersistentCache> cache_;
};

// Per-frame seed: any subset of frames renders the same images as the whole sequence.
std::uint64_t frame_seed(std::uint64_t seed, int frame);

// `pattern` with its run of '#' replaced by `frame`, zero-padded to the run's length (longer
// numbers are not cut). Throws dofcache::Error unless the file name has exactly one run of '#'.
std::string frame_path(const std::string& pattern, int frame);

// "<dir>/.<file name of pattern>.checkpoint.vdb", beside the frames.
std::string default_checkpoint_path(const std::string& pattern);

// A frame file that exists, reads back and has the frame's size: complete (what resume and
// `dofcache farm verify` count as done).
bool frame_complete(const std::string& path, int width, int height);

// "A-B" or "A" (frame numbers >= 0, A <= B). Throws dofcache::Error.
std::pair<int, int> parse_frame_range(const std::string& text);

// Hash of everything that determines frames[0..count): the cache identity, the render and cache
// settings that change pixels, the initial cache, and each frame's number, camera and lens.
std::uint64_t sequence_key(const scene::Scene& scene, const SequenceSettings& settings,
                           const std::vector<FrameSpec>& frames, std::size_t count,
                           std::uint64_t initial_cache_hash);

// Hash of a list of sample records (identifies a --cache-in file's contents).
std::uint64_t records_hash(const std::vector<cache::SampleRecord>& records);

}  // namespace dofcache::sequence
