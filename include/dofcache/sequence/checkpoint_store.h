#pragma once
// Where a persistent sequence keeps its checkpoint: a base (a full cache file with a
// SequenceCheckpoint, cache_file.h) and its journal (checkpoint_journal.h) beside it, and when a
// frame appends to the journal or writes a new base (compaction).
//
// Cost. A journal record holds the frame's new samples (64 bytes each), the ids of removed ones
// and one bit per kept sample; a base holds every sample. The first frame a run saves writes a
// base (there is no journal for its cache yet); later frames append while the journal stays
// within `journal_ratio` times the base's size, then the next writes a new base and an empty
// journal. With ratio 1 the bytes written per frame average at most about twice the records',
// and a resume reads at most twice the base's bytes (docs/sequence.md, "Checkpoints").
//
// Order. The sequence renderer saves after the frame's image is in place. A new base is renamed
// into place before its new journal: a run killed in between leaves the old journal, which names
// the old base and is not applied to the new one.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "dofcache/sequence/cache_file.h"
#include "dofcache/sequence/checkpoint_journal.h"

namespace dofcache::sequence {

class CheckpointStore {
 public:
  // `path`: the base; the journal is checkpoint_journal_path(path). `header`: the identity, scene
  // source and min_factor every base is written with (its records and checkpoint are ignored).
  // `journal_ratio` >= 0; 0 writes a base after every frame and no journal.
  CheckpointStore(std::string path, CacheFile header, double journal_ratio);

  const std::string& path() const { return path_; }
  std::string journal_path() const { return checkpoint_journal_path(path_); }

  // Appends after the first `complete_bytes` bytes of the journal, whose base (at path()) is
  // `base_bytes` long: after a resume that replayed the journal up to there.
  void continue_journal(std::uint64_t base_bytes, std::uint64_t complete_bytes);

  // The lens the next base records (the frame's it is saved after).
  void set_lens(lens::LensIdentity lens) { header_.lens = std::move(lens); }
  // Whether save() will want the frame's cache as the reuse rule left it (a journal is open).
  bool journaling() const { return journal_.has_value(); }

  struct Saved {
    std::uint64_t bytes = 0;  // written: a journal record, or a base and a journal header
    bool base = false;        // a new base
  };
  // Saves the cache `after` frame `checkpoint.frame`: a journal record of the change from
  // `before` (the cache after that frame's reuse rule; may be null when !journaling()) if the
  // journal has room, else a new base and an empty journal. Throws dofcache::Error.
  Saved save(const std::vector<cache::SampleRecord>& after, const std::vector<cache::SampleRecord>* before,
             const SequenceCheckpoint& checkpoint);

 private:
  Saved write_base(const std::vector<cache::SampleRecord>& after, const SequenceCheckpoint& checkpoint);

  std::string path_;
  CacheFile header_;
  double journal_ratio_;
  std::optional<CheckpointJournalWriter> journal_;
  std::uint64_t base_bytes_ = 0;
};

}  // namespace dofcache::sequence
