#include "dofcache/sequence/checkpoint_store.h"

#include <filesystem>

#include "dofcache/core/error.h"

namespace dofcache::sequence {

namespace fs = std::filesystem;

CheckpointStore::CheckpointStore(std::string path, CacheFile header, double journal_ratio)
    : path_(std::move(path)), header_(std::move(header)), journal_ratio_(journal_ratio) {
  header_.records.clear();
  header_.checkpoint.reset();
}

void CheckpointStore::continue_journal(std::uint64_t base_bytes, std::uint64_t complete_bytes) {
  if (journal_ratio_ <= 0.0) return;
  journal_ = CheckpointJournalWriter::extend(journal_path(), complete_bytes);
  base_bytes_ = base_bytes;
}

CheckpointStore::Saved CheckpointStore::save(const std::vector<cache::SampleRecord>& after,
                                             const std::vector<cache::SampleRecord>* before,
                                             const SequenceCheckpoint& checkpoint) {
  if (journal_ && before) {
    JournalRecord r;
    r.frame = checkpoint.frame;
    r.sequence_key = checkpoint.sequence_key;
    r.state_hash = state_hash(after);
    r.delta = frame_delta(*before, after, checkpoint.frame);
    std::string encoded = encode_journal_record(r);
    if (double(journal_->bytes() + encoded.size()) <= journal_ratio_ * double(base_bytes_))
      return Saved{journal_->append_encoded(encoded), false};
  }
  return write_base(after, checkpoint);
}

CheckpointStore::Saved CheckpointStore::write_base(const std::vector<cache::SampleRecord>& after,
                                                   const SequenceCheckpoint& checkpoint) {
  CacheFile file = header_;
  file.records = after;
  file.checkpoint = checkpoint;
  write_cache_file(path_, file);
  std::error_code ec;
  base_bytes_ = fs::file_size(path_, ec);
  if (ec) throw Error("cannot write '" + path_ + "': " + ec.message());
  Saved saved{base_bytes_, true};
  if (journal_ratio_ > 0.0) {
    journal_ = CheckpointJournalWriter::create(
        journal_path(), JournalBase{checkpoint.sequence_key, checkpoint.frame, state_hash(after)});
    saved.bytes += journal_->bytes();
  } else {
    // Without a journal, one left by an earlier run would only be refused at resume (it names
    // another base); removing it keeps the directory to what is in use.
    journal_.reset();
    fs::remove(journal_path(), ec);
  }
  return saved;
}

}  // namespace dofcache::sequence
