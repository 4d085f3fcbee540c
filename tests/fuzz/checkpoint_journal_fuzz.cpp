// Checkpoint journals (the per-frame records beside a persistent sequence's checkpoint). The
// target seals the input's checksums, as a forged journal would have them, so that mutations
// reach the record parser instead of stopping at a checksum; then it replays the records it
// accepts, as a resume does, on a cache made to fit the first one (its removed ids and as many
// kept samples as it says), so that the replay's merging runs too. Seeds: corpus/
// checkpoint_journal holds the journal of `dofcache sequence scenes/cornell_box_dolly.gltf
// --frames 0-3 --persistent --width 8 --spp 2 --light-samples 1 --gather-rays 4
// --cache-sample-quality 1` (frames 1-3), its first record alone, its header alone, and the
// journal cut short inside its last record.
#include <algorithm>
#include <string>
#include <unordered_set>
#include <vector>

#include "dofcache/sequence/checkpoint_journal.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dofcache;
  std::string bytes(reinterpret_cast<const char*>(data), size);
  sequence::seal_checkpoint_journal(bytes);
  fuzz::expect_clean([&] {
    sequence::CheckpointJournal j = sequence::parse_checkpoint_journal(bytes, "journal");
    if (j.records.empty()) return;
    const sequence::FrameDelta& first = j.records.front().delta;
    std::unordered_set<std::uint32_t> taken(first.removed.begin(), first.removed.end());
    for (const cache::SampleRecord& r : first.added) taken.insert(r.sample.id);
    std::vector<cache::SampleRecord> cache(first.removed.size());
    for (std::size_t i = 0; i < cache.size(); ++i) cache[i].sample.id = first.removed[i];
    for (std::uint32_t id = 0, kept = 0; kept < first.kept; ++id) {
      if (taken.count(id)) continue;
      cache.emplace_back().sample.id = id;
      ++kept;
    }
    std::sort(cache.begin(), cache.end(), [](const auto& a, const auto& b) {
      return a.sample.id < b.sample.id;
    });
    for (const sequence::JournalRecord& r : j.records)
      sequence::apply_frame_delta(cache, r.delta, r.frame);
  });
  return 0;
}
