#pragma once
// Content hashing: a stable 64-bit identity of some content, the same on every run and machine
// (hash_combine over the values in order). It identifies loaded scenes (Scene::content_hash) and
// sequences and their cache files (sequence_key, records_hash), so its values must never change.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>

#include "dofcache/core/rng.h"

namespace dofcache {

class ContentHasher {
 public:
  // Each kind of content starts from its own seed, so equal values of different kinds differ.
  explicit ContentHasher(std::uint64_t seed) : h_(seed) {}

  void add(std::uint64_t v) { h_ = hash_combine(h_, v); }
  void add(int i) { add(static_cast<std::uint64_t>(static_cast<std::int64_t>(i))); }
  void add(bool b) { add(static_cast<std::uint64_t>(b)); }
  // A double's bit pattern; -0 and +0 hash alike.
  void add(double d) {
    if (d == 0.0) d = 0.0;
    std::uint64_t bits;
    std::memcpy(&bits, &d, sizeof bits);
    add(bits);
  }
  // A float is widened to double first, so it hashes as the double it equals.
  void add(float f) { add(static_cast<double>(f)); }
  // A float's own 32-bit pattern (-0 and +0 alike): the convention of the scene hash.
  void add_float32(float f) {
    if (f == 0.0f) f = 0.0f;
    std::uint32_t bits;
    std::memcpy(&bits, &f, sizeof bits);
    add(static_cast<std::uint64_t>(bits));
  }
  // The length, then each byte.
  void add(const std::string& s) {
    add(static_cast<std::uint64_t>(s.size()));
    for (unsigned char c : s) add(static_cast<std::uint64_t>(c));
  }

  std::uint64_t value() const { return h_; }

 private:
  std::uint64_t h_;
};

// A checksum of `n` bytes: 8-byte little-endian words, then the zero-padded tail and the length,
// folded with hash_combine from `seed` (cache file trailers, checkpoint journal records).
inline std::uint64_t hash_bytes(const void* data, std::size_t n, std::uint64_t seed) {
  const char* bytes = static_cast<const char*>(data);
  std::uint64_t h = seed;
  std::size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    std::uint64_t w;
    std::memcpy(&w, bytes + i, 8);
    h = hash_combine(h, w);
  }
  std::uint64_t tail = 0;
  if (n > i) std::memcpy(&tail, bytes + i, n - i);
  return hash_combine(hash_combine(h, tail), n);
}

}  // namespace dofcache
