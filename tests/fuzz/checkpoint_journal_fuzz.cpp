// Checkpoint journals (the per-frame records beside a persistent sequence's checkpoint). The
// target seals the input's checksums, as a forged journal would have them, so that mutations
// reach the record parser instead of stopping at a checksum, then replays every record it
// accepts on a small cache, as a resume does. Seeds: corpus/checkpoint_journal holds the journal
// of `dofcache sequence scenes/cornell_box_dolly.gltf --persistent --frames 0-3` (32x24, 4 spp),
// one cut short inside its last record, and one of a single frame.
#include <string>
#include <vector>

#include "dofcache/sequence/checkpoint_journal.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dofcache;
  std::string bytes(reinterpret_cast<const char*>(data), size);
  sequence::seal_checkpoint_journal(bytes);
  fuzz::expect_clean([&] {
    sequence::CheckpointJournal j = sequence::parse_checkpoint_journal(bytes, "journal");
    std::vector<sequence::SampleRecord> cache(16);
    for (std::uint32_t id = 0; id < cache.size(); ++id) cache[id].sample.id = id;
    for (const sequence::JournalRecord& r : j.records)
      sequence::apply_frame_delta(cache, r.delta, r.frame);
  });
  return 0;
}
