// Checkpoint journals (layout in checkpoint_journal.h): plain binary I/O, no OpenVDB.
#include "dofcache/sequence/checkpoint_journal.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <iterator>

#include "dofcache/core/atomic_file.h"
#include "dofcache/core/content_hash.h"
#include "dofcache/core/error.h"
#include "dofcache/core/file.h"
#include "dofcache/sequence/cache_file.h"

namespace dofcache::sequence {
namespace {

constexpr char kMagic[8] = {'D', 'O', 'F', 'C', 'J', 'N', 'L', '1'};
constexpr std::uint32_t kVersion = 1;
constexpr std::uint64_t kHeaderSeed = 0x6a6f75726e616cULL;   // "journal"
constexpr std::uint64_t kRecordSeed = 0x6672616d656a6eULL;   // "framejn"
constexpr std::uint64_t kStateSeed = 0x7374617465686aULL;    // "statehj"
constexpr std::size_t kRecordPrefixBytes = 16;               // length, checksum
constexpr std::size_t kPayloadFixedBytes = 40;
constexpr std::size_t kSampleBytes = 64;

void store32(char* p, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<char>(v >> (8 * i) & 0xff);
}
void put32(std::string& out, std::uint32_t v) {
  char b[4];
  store32(b, v);
  out.append(b, 4);
}
void put64(std::string& out, std::uint64_t v) {
  put32(out, static_cast<std::uint32_t>(v));
  put32(out, static_cast<std::uint32_t>(v >> 32));
}
void store_float(char* p, float f) {
  std::uint32_t bits;
  std::memcpy(&bits, &f, 4);
  store32(p, bits);
}
std::uint32_t get32(const char* p) {
  std::uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= std::uint32_t(static_cast<unsigned char>(p[i])) << (8 * i);
  return v;
}
std::uint64_t get64(const char* p) {
  return std::uint64_t(get32(p)) | std::uint64_t(get32(p + 4)) << 32;
}
float get_float(const char* p) {
  std::uint32_t bits = get32(p);
  float f;
  std::memcpy(&f, &bits, 4);
  return f;
}

// The 64-byte encoding of a sample (checkpoint_journal.h).
void store_sample(char* p, const cache::SampleRecord& r) {
  const cache::CacheSample& s = r.sample;
  for (const glm::vec3* v : {&s.position, &s.normal, &s.value})
    for (int k = 0; k < 3; ++k, p += 4) store_float(p, (*v)[k]);
  store_float(p, s.radius);
  store_float(p + 4, r.origin.radius);
  store_float(p + 8, r.origin.view_radius);
  store_float(p + 12, r.origin.footprint);
  store32(p + 16, s.id);
  store32(p + 20, s.frame);
  store32(p + 24, static_cast<std::uint32_t>(r.last_used));
}
void put_sample(std::string& out, const cache::SampleRecord& r) {
  char b[kSampleBytes];
  store_sample(b, r);
  out.append(b, kSampleBytes);
}

cache::SampleRecord get_sample(const char* p) {
  cache::SampleRecord r;
  cache::CacheSample& s = r.sample;
  for (glm::vec3* v : {&s.position, &s.normal, &s.value})
    for (int k = 0; k < 3; ++k, p += 4) (*v)[k] = get_float(p);
  s.radius = get_float(p);
  r.origin.radius = get_float(p + 4);
  r.origin.view_radius = get_float(p + 8);
  r.origin.footprint = get_float(p + 12);
  s.id = get32(p + 16);
  s.frame = get32(p + 20);
  r.last_used = static_cast<std::int32_t>(get32(p + 24));
  return r;
}

// Equal in every bit but last_used (what the encoding holds; compared field by field, since this
// runs for every sample of every frame).
bool same_but_last_used(const cache::SampleRecord& a, const cache::SampleRecord& b) {
  const cache::CacheSample &x = a.sample, &y = b.sample;
  auto same = [](const auto& u, const auto& v) { return std::memcmp(&u, &v, sizeof u) == 0; };
  return same(x.position, y.position) && same(x.normal, y.normal) && same(x.value, y.value) &&
         same(x.radius, y.radius) && x.id == y.id && x.frame == y.frame &&
         same(a.origin.radius, b.origin.radius) &&
         same(a.origin.view_radius, b.origin.view_radius) &&
         same(a.origin.footprint, b.origin.footprint);
}

bool bit(const std::vector<std::uint8_t>& bits, std::size_t k) {
  return (bits[k / 8] >> (k % 8) & 1) != 0;
}

// One record's payload; throws dofcache::Error (the reason, without the file name) if malformed.
JournalRecord parse_payload(const char* p, std::uint64_t length) {
  auto bad = [](const std::string& why) { return Error("a record is malformed (" + why + ")"); };
  if (length < kPayloadFixedBytes) throw bad("shorter than its fixed part");
  JournalRecord r;
  r.frame = static_cast<std::int32_t>(get32(p));
  r.sequence_key = get64(p + 8);
  r.state_hash = get64(p + 16);
  const std::uint64_t removed = get32(p + 24), kept = get32(p + 28), added = get32(p + 32);
  if (get32(p + 4) != 0 || get32(p + 36) != 0) throw bad("reserved fields are not zero");
  // Counts are at most 2^32 each, so this sum cannot overflow; it must be the length exactly.
  const std::uint64_t expected =
      kPayloadFixedBytes + 4 * removed + (kept + 7) / 8 + kSampleBytes * added;
  if (expected != length) throw bad("its counts disagree with its length");
  FrameDelta& d = r.delta;
  const char* q = p + kPayloadFixedBytes;
  d.removed.resize(removed);
  for (std::uint64_t i = 0; i < removed; ++i, q += 4) {
    d.removed[i] = get32(q);
    if (i > 0 && d.removed[i] <= d.removed[i - 1]) throw bad("removed ids out of order");
  }
  d.kept = static_cast<std::uint32_t>(kept);
  d.used.assign(q, q + (kept + 7) / 8);
  q += (kept + 7) / 8;
  if (kept % 8 != 0 && (d.used.back() >> (kept % 8)) != 0) throw bad("stray bits");
  d.added.reserve(added);
  for (std::uint64_t i = 0; i < added; ++i, q += kSampleBytes) {
    d.added.push_back(get_sample(q));
    const cache::SampleRecord& s = d.added.back();
    if (!valid_sample_record(s)) throw bad("an invalid sample, id " + std::to_string(s.sample.id));
    if (i > 0 && s.sample.id <= d.added[i - 1].sample.id) throw bad("added ids out of order");
  }
  return r;
}

}  // namespace

FrameDelta frame_delta(const std::vector<cache::SampleRecord>& before,
                       const std::vector<cache::SampleRecord>& after, std::int32_t frame) {
  FrameDelta d;
  std::vector<bool> used;
  std::size_t i = 0, j = 0;
  while (i < before.size() || j < after.size()) {
    const std::uint32_t a = i < before.size() ? before[i].sample.id : UINT32_MAX;
    const std::uint32_t b = j < after.size() ? after[j].sample.id : UINT32_MAX;
    if (i < before.size() && (j == after.size() || a < b)) {
      d.removed.push_back(a);
      ++i;
    } else if (i == before.size() || b < a) {
      d.added.push_back(after[j]);
      ++j;
    } else {
      const cache::SampleRecord &x = before[i], &y = after[j];
      if (same_but_last_used(x, y) && (y.last_used == x.last_used || y.last_used == frame)) {
        used.push_back(y.last_used != x.last_used);
      } else {  // changed otherwise: stored whole
        d.removed.push_back(a);
        d.added.push_back(y);
      }
      ++i, ++j;
    }
  }
  d.kept = static_cast<std::uint32_t>(used.size());
  d.used.assign((used.size() + 7) / 8, 0);
  for (std::size_t k = 0; k < used.size(); ++k)
    if (used[k]) d.used[k / 8] |= static_cast<std::uint8_t>(1u << (k % 8));
  return d;
}

void apply_frame_delta(std::vector<cache::SampleRecord>& records, const FrameDelta& delta,
                       std::int32_t frame) {
  if (delta.used.size() != (std::size_t{delta.kept} + 7) / 8)
    throw Error("the frame's changes are malformed (used bits for " +
                std::to_string(delta.kept) + " samples)");
  std::vector<cache::SampleRecord> kept;
  kept.reserve(records.size());
  std::size_t r = 0;
  for (const cache::SampleRecord& s : records) {
    if (r < delta.removed.size() && delta.removed[r] < s.sample.id) break;  // missing: below
    if (r < delta.removed.size() && delta.removed[r] == s.sample.id) {
      ++r;
      continue;
    }
    if (kept.size() == delta.kept) {
      kept.push_back(s);  // one too many: reported below
      break;
    }
    kept.push_back(s);
    if (bit(delta.used, kept.size() - 1)) kept.back().last_used = frame;
  }
  if (r != delta.removed.size())
    throw Error("the frame's changes remove sample " + std::to_string(delta.removed[r]) +
                ", which the cache does not hold");
  if (kept.size() != delta.kept)
    throw Error("the frame's changes keep " + std::to_string(delta.kept) + " samples, the cache " +
                "has " + std::to_string(records.size() - delta.removed.size()) + " left");
  std::vector<cache::SampleRecord> out;
  out.reserve(kept.size() + delta.added.size());
  std::size_t k = 0, a = 0;
  while (k < kept.size() || a < delta.added.size()) {
    if (a == delta.added.size() ||
        (k < kept.size() && kept[k].sample.id < delta.added[a].sample.id)) {
      out.push_back(kept[k++]);
    } else if (k == kept.size() || delta.added[a].sample.id < kept[k].sample.id) {
      out.push_back(delta.added[a++]);
    } else {
      throw Error("the frame's changes add sample " + std::to_string(kept[k].sample.id) +
                  ", which the cache already holds");
    }
  }
  records = std::move(out);
}

std::uint64_t state_hash(const std::vector<cache::SampleRecord>& records) {
  char b[kSampleBytes];
  std::uint64_t h = kStateSeed;
  for (const cache::SampleRecord& r : records) {
    store_sample(b, r);
    h = hash_bytes(b, kSampleBytes, h);
  }
  return hash_combine(h, records.size());
}

std::string encode_journal_header(const JournalBase& base) {
  std::string out(kMagic, sizeof kMagic);
  put64(out, base.sequence_key);
  put32(out, static_cast<std::uint32_t>(base.frame));
  put32(out, kVersion);
  put64(out, base.state_hash);
  put64(out, hash_bytes(out.data(), out.size(), kHeaderSeed));
  return out;
}

std::string encode_journal_record(const JournalRecord& record) {
  const FrameDelta& d = record.delta;
  std::string payload;
  payload.reserve(kPayloadFixedBytes + 4 * d.removed.size() + d.used.size() +
                  kSampleBytes * d.added.size());
  put32(payload, static_cast<std::uint32_t>(record.frame));
  put32(payload, 0);
  put64(payload, record.sequence_key);
  put64(payload, record.state_hash);
  put32(payload, static_cast<std::uint32_t>(d.removed.size()));
  put32(payload, d.kept);
  put32(payload, static_cast<std::uint32_t>(d.added.size()));
  put32(payload, 0);
  for (std::uint32_t id : d.removed) put32(payload, id);
  payload.append(d.used.begin(), d.used.end());
  for (const cache::SampleRecord& r : d.added) put_sample(payload, r);
  std::string out;
  out.reserve(kRecordPrefixBytes + payload.size());
  put64(out, payload.size());
  put64(out, hash_bytes(payload.data(), payload.size(), kRecordSeed));
  return out + payload;
}

CheckpointJournal parse_checkpoint_journal(const std::string& bytes, const std::string& name) {
  if (bytes.size() < kJournalHeaderBytes || std::memcmp(bytes.data(), kMagic, 8) != 0)
    throw Error(name + ": not a dofcache checkpoint journal");
  const char* p = bytes.data();
  if (get64(p + 32) != hash_bytes(p, 32, kHeaderSeed))
    throw Error(name + ": checkpoint journal header is damaged (checksum mismatch)");
  if (get32(p + 20) != kVersion)
    throw Error(name + ": checkpoint journal version " + std::to_string(get32(p + 20)) +
                " is not supported (this build reads version " + std::to_string(kVersion) + ")");
  CheckpointJournal j;
  j.base.sequence_key = get64(p + 8);
  j.base.frame = static_cast<std::int32_t>(get32(p + 16));
  j.base.state_hash = get64(p + 24);
  std::uint64_t pos = kJournalHeaderBytes;
  std::int32_t last_frame = j.base.frame;
  while (pos < bytes.size()) {
    const std::uint64_t left = bytes.size() - pos;
    if (left < kRecordPrefixBytes) {
      j.tail = "its last record is cut short";
      break;
    }
    const std::uint64_t length = get64(p + pos), sum = get64(p + pos + 8);
    if (length > left - kRecordPrefixBytes) {
      j.tail = "its last record is cut short";
      break;
    }
    const char* payload = p + pos + kRecordPrefixBytes;
    if (sum != hash_bytes(payload, length, kRecordSeed)) {
      j.tail = "a record is damaged (checksum mismatch)";
      break;
    }
    try {
      JournalRecord r = parse_payload(payload, length);
      if (r.frame <= last_frame)
        throw Error("a record's frame " + std::to_string(r.frame) + " does not follow frame " +
                    std::to_string(last_frame));
      last_frame = r.frame;
      j.records.push_back(std::move(r));
    } catch (const Error& e) {
      j.tail = e.what();
      break;
    }
    pos += kRecordPrefixBytes + length;
    j.ends.push_back(pos);
  }
  j.complete_bytes = pos;
  return j;
}

CheckpointJournal read_checkpoint_journal(const std::string& path) {
  return parse_checkpoint_journal(read_file(path, "the checkpoint journal"), path);
}

void seal_checkpoint_journal(std::string& bytes) {
  auto store64 = [&](std::size_t at, std::uint64_t v) {
    store32(&bytes[at], static_cast<std::uint32_t>(v));
    store32(&bytes[at + 4], static_cast<std::uint32_t>(v >> 32));
  };
  if (bytes.size() < kJournalHeaderBytes) return;
  store64(32, hash_bytes(bytes.data(), 32, kHeaderSeed));
  std::uint64_t pos = kJournalHeaderBytes;
  while (bytes.size() - pos >= kRecordPrefixBytes) {
    const std::uint64_t length = get64(bytes.data() + pos);
    if (length > bytes.size() - pos - kRecordPrefixBytes) break;
    store64(pos + 8, hash_bytes(bytes.data() + pos + kRecordPrefixBytes, length, kRecordSeed));
    pos += kRecordPrefixBytes + length;
  }
}

std::string checkpoint_journal_path(const std::string& checkpoint) {
  return checkpoint + ".journal";
}

CheckpointJournalWriter CheckpointJournalWriter::create(const std::string& path,
                                                        const JournalBase& base) {
  const std::string header = encode_journal_header(base);
  write_bytes_atomically(path, header);
  return CheckpointJournalWriter(path, header.size());
}

CheckpointJournalWriter CheckpointJournalWriter::extend(const std::string& path,
                                                        std::uint64_t complete_bytes) {
  if (complete_bytes < kJournalHeaderBytes)
    throw Error(path + ": a checkpoint journal is at least its header");
  return CheckpointJournalWriter(path, complete_bytes);
}

std::size_t CheckpointJournalWriter::append(const JournalRecord& record) {
  return append_encoded(encode_journal_record(record));
}

std::size_t CheckpointJournalWriter::append_encoded(const std::string& encoded) {
  auto fail = [&](const char* what) {
    return Error("cannot write '" + path_ + "': " + what + " (" + std::strerror(errno) + ")");
  };
  int fd = ::open(path_.c_str(), O_WRONLY | O_CLOEXEC);
  if (fd < 0) throw fail("cannot open the checkpoint journal");
  struct stat st;
  // What follows the complete records (a record cut short by a killed run) is cut off first.
  if (::fstat(fd, &st) != 0 ||
      (static_cast<std::uint64_t>(st.st_size) != bytes_ &&
       ::ftruncate(fd, static_cast<off_t>(bytes_)) != 0)) {
    Error e = fail("cannot truncate the checkpoint journal");
    ::close(fd);
    throw e;
  }
  // One write: a run killed during it leaves at most this record incomplete.
  std::size_t done = 0;
  while (done < encoded.size()) {
    ssize_t n = ::pwrite(fd, encoded.data() + done, encoded.size() - done,
                         static_cast<off_t>(bytes_ + done));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      Error e = fail("cannot append to the checkpoint journal");
      ::close(fd);
      throw e;
    }
    done += static_cast<std::size_t>(n);
  }
  if (::close(fd) != 0) throw fail("cannot close the checkpoint journal");
  bytes_ += encoded.size();
  return encoded.size();
}

}  // namespace dofcache::sequence
