// Checkpoint journals: a frame's changes round-trip exactly through a record, a record cut short
// or damaged ends the journal where it starts (the records before it stay usable), a damaged
// header is refused in one line, and counts that disagree with a record's length are refused
// before anything is allocated for them.
#include <gtest/gtest.h>

#include "scratch_dir.h"

#include <cmath>
#include <filesystem>
#include <fstream>

#include "dofcache/core/error.h"
#include "dofcache/sequence/checkpoint_journal.h"

using namespace dofcache;
using namespace dofcache::sequence;
namespace fs = std::filesystem;

namespace {

class JournalTest : public dofcache::testing::ScratchDirTest {};

cache::SampleRecord sample(std::uint32_t id, std::int32_t last_used) {
  cache::SampleRecord r;
  r.sample.position = {0.1f * float(id), -0.25f, 1.5f + float(id)};
  r.sample.normal = {0.0f, 1.0f, 0.0f};
  r.sample.value = {0.5f, 0.125f * float(id % 4), 2.0f};
  r.sample.radius = 0.01f + 0.001f * float(id);
  r.sample.frame = id / 4;
  r.sample.id = id;
  r.origin = {0.02f, 0.015f, 0.001f};
  r.last_used = last_used;
  return r;
}

// Ten samples 0..9 at the start of frame 7 (after its reuse rule), last used in frames 3-6.
std::vector<cache::SampleRecord> start_of_frame() {
  std::vector<cache::SampleRecord> v;
  for (std::uint32_t id = 0; id < 10; ++id) v.push_back(sample(id, 3 + std::int32_t(id % 4)));
  return v;
}

// What frame 7 did: used 1 and 3, evicted 2 and 5, changed 7's value, added 10 and 11.
std::vector<cache::SampleRecord> end_of_frame() {
  std::vector<cache::SampleRecord> v;
  for (cache::SampleRecord r : start_of_frame()) {
    std::uint32_t id = r.sample.id;
    if (id == 2 || id == 5) continue;
    if (id == 1 || id == 3) r.last_used = 7;
    if (id == 7) r.sample.value.x = 0.75f;
    v.push_back(r);
  }
  v.push_back(sample(10, 7));
  v.push_back(sample(11, 7));
  return v;
}

bool same(const std::vector<cache::SampleRecord>& a, const std::vector<cache::SampleRecord>& b) {
  return state_hash(a) == state_hash(b);
}

JournalRecord record_of_frame7() {
  JournalRecord r;
  r.frame = 7;
  r.sequence_key = 0x1234567890abcdefULL;
  r.state_hash = state_hash(end_of_frame());
  r.delta = frame_delta(start_of_frame(), end_of_frame(), 7);
  return r;
}

void write(const fs::path& p, const std::string& bytes) {
  std::ofstream(p, std::ios::binary | std::ios::trunc) << bytes;
}

TEST(FrameDelta, HoldsExactlyWhatTheFrameChanged) {
  FrameDelta d = frame_delta(start_of_frame(), end_of_frame(), 7);
  EXPECT_EQ(d.removed, (std::vector<std::uint32_t>{2, 5, 7}));  // 7 changed: stored whole
  ASSERT_EQ(d.added.size(), 3u);
  EXPECT_EQ(d.added[0].sample.id, 7u);
  EXPECT_EQ(d.added[0].sample.value.x, 0.75f);
  EXPECT_EQ(d.added[1].sample.id, 10u);
  EXPECT_EQ(d.added[2].sample.id, 11u);
  // Kept: 0 1 3 4 6 8 9; used among them: 1 and 3 (positions 1 and 2).
  EXPECT_EQ(d.kept, 7u);
  EXPECT_EQ(d.used, (std::vector<std::uint8_t>{0x06}));

  std::vector<cache::SampleRecord> replayed = start_of_frame();
  apply_frame_delta(replayed, d, 7);
  EXPECT_TRUE(same(replayed, end_of_frame()));
  EXPECT_FALSE(same(replayed, start_of_frame()));
  EXPECT_EQ(replayed[1].last_used, 7);   // id 1
  EXPECT_EQ(replayed[3].last_used, 3);   // id 4, unused: as it was
}

TEST(FrameDelta, NoChangeIsAnEmptyDelta) {
  FrameDelta d = frame_delta(start_of_frame(), start_of_frame(), 7);
  EXPECT_TRUE(d.removed.empty());
  EXPECT_TRUE(d.added.empty());
  EXPECT_EQ(d.kept, 10u);
  EXPECT_EQ(d.used, (std::vector<std::uint8_t>{0, 0}));
}

TEST(FrameDelta, ADeltaThatDoesNotFitIsRefusedAndChangesNothing) {
  FrameDelta d = frame_delta(start_of_frame(), end_of_frame(), 7);
  std::vector<cache::SampleRecord> other = start_of_frame();
  other.erase(other.begin() + 5);  // sample 5 is gone already
  const std::uint64_t before = state_hash(other);
  EXPECT_THROW(apply_frame_delta(other, d, 7), Error);
  EXPECT_EQ(state_hash(other), before);
  std::vector<cache::SampleRecord> bigger = start_of_frame();
  bigger.push_back(sample(12, 6));  // one more kept sample than the delta knows
  EXPECT_THROW(apply_frame_delta(bigger, d, 7), Error);
  std::vector<cache::SampleRecord> clash = start_of_frame();
  clash.push_back(sample(11, 6));  // the frame adds 11, already there
  d.kept = 8;                      // (so that only the clash is wrong)
  d.used.assign(1, 0);
  EXPECT_THROW(apply_frame_delta(clash, d, 7), Error);
}

TEST(StateHash, SeesEveryBit) {
  std::vector<cache::SampleRecord> a = start_of_frame(), b = a;
  EXPECT_EQ(state_hash(a), state_hash(b));
  b[4].sample.radius = std::nextafter(b[4].sample.radius, 1.0f);
  EXPECT_NE(state_hash(a), state_hash(b));
  b = a;
  b[9].last_used += 1;
  EXPECT_NE(state_hash(a), state_hash(b));
  b = a;
  b[0].sample.position.x = -0.0f;  // +0 in a
  EXPECT_NE(state_hash(a), state_hash(b));
}

TEST_F(JournalTest, RecordsRoundTripThroughTheFile) {
  const std::string file = path("cp.vdb.journal");
  CheckpointJournalWriter w = CheckpointJournalWriter::create(file, {0xabcULL, 6, 0x5151ULL});
  EXPECT_EQ(w.bytes(), kJournalHeaderBytes);
  JournalRecord r7 = record_of_frame7();
  std::size_t n7 = w.append(r7);
  JournalRecord r9;
  r9.frame = 9;
  r9.sequence_key = 99;
  r9.state_hash = 98;
  r9.delta.kept = 12;
  r9.delta.used = {0xff, 0x0f};
  std::size_t n9 = w.append(r9);
  EXPECT_EQ(fs::file_size(file), kJournalHeaderBytes + n7 + n9);
  EXPECT_EQ(w.bytes(), fs::file_size(file));

  CheckpointJournal j = read_checkpoint_journal(file);
  EXPECT_EQ(j.base.sequence_key, 0xabcULL);
  EXPECT_EQ(j.base.frame, 6);
  EXPECT_EQ(j.base.state_hash, 0x5151ULL);
  EXPECT_TRUE(j.tail.empty()) << j.tail;
  EXPECT_EQ(j.complete_bytes, fs::file_size(file));
  ASSERT_EQ(j.records.size(), 2u);
  EXPECT_EQ(j.ends, (std::vector<std::uint64_t>{kJournalHeaderBytes + n7,
                                                kJournalHeaderBytes + n7 + n9}));
  const JournalRecord& back = j.records[0];
  EXPECT_EQ(back.frame, 7);
  EXPECT_EQ(back.sequence_key, r7.sequence_key);
  EXPECT_EQ(back.state_hash, r7.state_hash);
  EXPECT_EQ(back.delta.removed, r7.delta.removed);
  EXPECT_EQ(back.delta.kept, r7.delta.kept);
  EXPECT_EQ(back.delta.used, r7.delta.used);
  EXPECT_TRUE(same(back.delta.added, r7.delta.added));
  std::vector<cache::SampleRecord> replayed = start_of_frame();
  apply_frame_delta(replayed, back.delta, 7);
  EXPECT_EQ(state_hash(replayed), back.state_hash);
  EXPECT_EQ(j.records[1].delta.used, r9.delta.used);
  // 40 fixed bytes, 3 removed ids, 1 byte of used bits, 3 samples of 64 bytes, 16 of prefix.
  EXPECT_EQ(n7, 16u + 40u + 12u + 1u + 192u);
}

TEST_F(JournalTest, ARecordCutShortEndsTheJournalBeforeIt) {
  std::string header = encode_journal_header({1, 0, 2});
  std::string r1 = encode_journal_record(record_of_frame7());
  JournalRecord next = record_of_frame7();
  next.frame = 8;
  std::string r2 = encode_journal_record(next);
  const std::string whole = header + r1 + r2;
  for (std::size_t cut : {std::size_t{1}, std::size_t{8}, std::size_t{16}, std::size_t{17},
                          r2.size() - 1}) {
    CheckpointJournal j = parse_checkpoint_journal(whole.substr(0, whole.size() - cut), "j");
    ASSERT_EQ(j.records.size(), 1u) << cut;
    EXPECT_EQ(j.records[0].frame, 7);
    EXPECT_EQ(j.complete_bytes, header.size() + r1.size());
    EXPECT_NE(j.tail.find("cut short"), std::string::npos) << j.tail;
  }
  CheckpointJournal j = parse_checkpoint_journal(header + r1, "j");
  EXPECT_TRUE(j.tail.empty());

  // Appending after the complete part writes over the cut record.
  const std::string file = path("j");
  write(file, whole.substr(0, whole.size() - 5));
  CheckpointJournalWriter w = CheckpointJournalWriter::extend(file, header.size() + r1.size());
  w.append(next);
  CheckpointJournal again = read_checkpoint_journal(file);
  EXPECT_TRUE(again.tail.empty()) << again.tail;
  ASSERT_EQ(again.records.size(), 2u);
  EXPECT_EQ(again.records[1].frame, 8);
  EXPECT_EQ(fs::file_size(file), whole.size());
}

TEST_F(JournalTest, DamagedBytesAreRefused) {
  std::string header = encode_journal_header({1, 0, 2});
  std::string r1 = encode_journal_record(record_of_frame7());
  JournalRecord next = record_of_frame7();
  next.frame = 8;
  std::string r2 = encode_journal_record(next);
  // In a record: the journal ends before it.
  for (std::size_t at : {header.size() + r1.size() + 20, header.size() + r1.size() + r2.size() - 1}) {
    std::string bad = header + r1 + r2;
    bad[at] ^= 0x10;
    CheckpointJournal j = parse_checkpoint_journal(bad, "j");
    EXPECT_EQ(j.records.size(), 1u);
    EXPECT_NE(j.tail.find("checksum"), std::string::npos) << j.tail;
  }
  // In the header, or not a journal at all: refused in one line naming the file.
  for (std::size_t at : {std::size_t{3}, std::size_t{12}, std::size_t{30}}) {
    std::string bad = header + r1;
    bad[at] ^= 0x01;
    try {
      parse_checkpoint_journal(bad, "cp.journal");
      ADD_FAILURE() << "damaged header at byte " << at << " accepted";
    } catch (const Error& e) {
      std::string m = e.what();
      EXPECT_EQ(m.rfind("cp.journal: ", 0), 0u) << m;
      EXPECT_EQ(m.find('\n'), std::string::npos) << m;
    }
  }
  EXPECT_THROW(parse_checkpoint_journal("", "j"), Error);
  EXPECT_THROW(parse_checkpoint_journal(header.substr(0, 39), "j"), Error);
  EXPECT_THROW(read_checkpoint_journal(path("missing")), Error);
  // Records out of order: the second is not after the first.
  std::string twice = header + r1 + r1;
  CheckpointJournal j = parse_checkpoint_journal(twice, "j");
  EXPECT_EQ(j.records.size(), 1u);
  EXPECT_NE(j.tail.find("does not follow"), std::string::npos) << j.tail;
}

// A record sealed with a valid checksum whose counts claim more than its length holds: refused
// from the length alone (counts of 2^32 - 1 samples would be 256 GiB).
TEST(JournalRecords, CountsAreCheckedAgainstTheLength) {
  const std::string header = encode_journal_header({1, 0, 2});
  const std::string record = encode_journal_record(record_of_frame7());
  const std::size_t payload = 16;  // the record's length and checksum come first
  for (std::size_t field : {24u, 28u, 32u}) {  // removed, kept, added
    std::string forged = header + record;
    for (std::size_t k = 0; k < 4; ++k) forged[header.size() + payload + field + k] = '\xff';
    seal_checkpoint_journal(forged);
    CheckpointJournal j = parse_checkpoint_journal(forged, "j");
    EXPECT_TRUE(j.records.empty());
    EXPECT_NE(j.tail.find("counts disagree"), std::string::npos) << field << ": " << j.tail;
  }
  // An invalid sample: the first added sample's value.x made a NaN (0x7fc00000).
  std::string forged = header + record;
  const std::size_t value_x = header.size() + payload + 40 + 12 + 1 + 24;
  forged.replace(value_x, 4, std::string("\x00\x00\xc0\x7f", 4));
  seal_checkpoint_journal(forged);
  CheckpointJournal j = parse_checkpoint_journal(forged, "j");
  EXPECT_TRUE(j.records.empty());
  EXPECT_NE(j.tail.find("invalid sample"), std::string::npos) << j.tail;
  // Sealing what the writer made changes nothing.
  std::string sealed = header + record;
  seal_checkpoint_journal(sealed);
  EXPECT_EQ(sealed, header + record);
}

}  // namespace
