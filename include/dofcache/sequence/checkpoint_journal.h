#pragma once
// Checkpoint journals: the checkpoint of a persistent sequence as a full cache file (the base,
// cache_file.h) plus an append-only journal of what each later frame changed, so that a frame's
// checkpoint costs in proportion to that change instead of rewriting the whole cache
// (docs/sequence.md, "Checkpoints").
//
// What a frame changes in a persistent cache (persistent_cache.h): the reuse rule gives every
// sample a new radius, lookups mark samples used (last_used = the frame), new samples enter and
// eviction removes some. The radii are a function of the previous radius and the frame's camera,
// so a replay recomputes them (cache::apply_reuse_rule) instead of storing 4 bytes per sample and frame;
// a record stores the rest as a FrameDelta, and the hash of the whole cache after the frame, so a
// replay that would not reproduce the cache bit for bit is refused rather than rendering other
// frames than the uninterrupted run.
//
// Layout of "<checkpoint>.journal" (little-endian):
//   header  40 bytes: "DOFCJNL1", u64 the base's sequence key, i32 the base's frame, u32 version
//           (1), u64 state_hash of the base's samples, u64 hash_bytes of the 32 bytes before it
//   record  u64 payload length, u64 hash_bytes of the payload, then the payload:
//             i32 frame, u32 0, u64 sequence key (frames up to this one), u64 state hash after it,
//             u32 removed, u32 kept, u32 added, u32 0,
//             removed x u32 id (increasing),
//             ceil(kept / 8) bytes: bit k (byte k/8, bit k%8) set if the k-th kept sample (in id
//               order) was used in the frame,
//             added x 64 bytes: position, normal, value (3 f32 each), radius, origin radius,
//               view radius, footprint (f32), id, frame (u32), last_used (i32); increasing id
//
// Records are appended with one write each. A record cut short (a run killed while writing it)
// or damaged ends the journal where it starts: everything before it is used, and the next record
// is written over it. A journal only extends the base it names (sequence key, frame and state
// hash), so one left behind by an older base is never applied to a newer one.
#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "dofcache/cache/persistent_cache.h"

namespace dofcache::sequence {

// What one frame changed in a persistent cache, apart from the reuse rule's radii.
struct FrameDelta {
  std::vector<std::uint32_t> removed;  // ids gone (evicted, or replaced by an entry of `added`)
  std::uint32_t kept = 0;              // samples of the frame's start that stay unchanged
  std::vector<std::uint8_t> used;      // (kept + 7) / 8 bytes: kept samples now last used here
  std::vector<cache::SampleRecord> added;     // new samples (and new versions of changed ones)
};

// The delta from `before` (the cache after frame `frame`'s reuse rule) to `after` (after the
// frame), both in increasing id. A sample that changed in anything but last_used = `frame` is
// stored as removed and added, so the delta describes any change exactly.
FrameDelta frame_delta(const std::vector<cache::SampleRecord>& before,
                       const std::vector<cache::SampleRecord>& after, std::int32_t frame);

// Applies `delta` to `records` (the cache after frame `frame`'s reuse rule, increasing id).
// Throws dofcache::Error (records unchanged) if it does not fit them: an id to remove that is
// missing, a kept count that differs, an added id that is already there.
void apply_frame_delta(std::vector<cache::SampleRecord>& records, const FrameDelta& delta,
                       std::int32_t frame);

// Hash of every bit of a list of samples (the 64-byte encoding above, in order).
std::uint64_t state_hash(const std::vector<cache::SampleRecord>& records);

// The base a journal extends: the full checkpoint after `frame`.
struct JournalBase {
  std::uint64_t sequence_key = 0;
  std::int32_t frame = 0;
  std::uint64_t state_hash = 0;
};

struct JournalRecord {
  std::int32_t frame = 0;
  std::uint64_t sequence_key = 0;  // of the frames up to and including this one
  std::uint64_t state_hash = 0;    // of the cache after this frame
  FrameDelta delta;
};

constexpr std::size_t kJournalHeaderBytes = 40;

std::string encode_journal_header(const JournalBase& base);
// Length, checksum and payload: what one append writes.
std::string encode_journal_record(const JournalRecord& record);

struct CheckpointJournal {
  JournalBase base;
  std::vector<JournalRecord> records;  // in increasing frame, each after the base's frame
  std::vector<std::uint64_t> ends;     // the byte offset after each record
  // The header and the complete records: where the next record is written.
  std::uint64_t complete_bytes = 0;
  // Why the bytes after complete_bytes were not used (a record cut short or damaged); empty if
  // the file ends with a complete record.
  std::string tail;
};

// Parses a journal's bytes. Throws dofcache::Error (one line starting with `name`) if the header
// is not a valid journal header; records are checked one by one, the first that fails (cut
// short, checksum mismatch, counts that disagree with its length, ids out of order, invalid
// samples, a frame not after the previous one) ends the journal (CheckpointJournal::tail).
// Nothing is allocated before the bytes it describes are known to be there.
CheckpointJournal parse_checkpoint_journal(const std::string& bytes, const std::string& name);
CheckpointJournal read_checkpoint_journal(const std::string& path);

// Rewrites the checksums of the header and of every record whose length fits in `bytes`, as a
// forged journal would have them (public so that tests and the fuzz target can seal hand-made
// or mutated journals and reach the checks behind the checksums).
void seal_checkpoint_journal(std::string& bytes);

// "<checkpoint>.journal".
std::string checkpoint_journal_path(const std::string& checkpoint);

// Appends records to a journal file.
class CheckpointJournalWriter {
 public:
  // Starts the journal of `base` at `path`, replacing any file there (atomically: the header).
  static CheckpointJournalWriter create(const std::string& path, const JournalBase& base);
  // Continues a journal whose first `complete_bytes` bytes are its header and complete records
  // (CheckpointJournal::complete_bytes); the first append overwrites whatever follows them.
  static CheckpointJournalWriter extend(const std::string& path, std::uint64_t complete_bytes);

  // Writes one record (one write call) after the last. Returns the bytes written. Throws
  // dofcache::Error if the file cannot be written.
  std::size_t append(const JournalRecord& record);
  std::size_t append_encoded(const std::string& encoded);

  const std::string& path() const { return path_; }
  std::uint64_t bytes() const { return bytes_; }  // header and records

 private:
  CheckpointJournalWriter(std::string path, std::uint64_t bytes)
      : path_(std::move(path)), bytes_(bytes) {}
  std::string path_;
  std::uint64_t bytes_ = 0;
};

}  // namespace dofcache::sequence
