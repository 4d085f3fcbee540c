#pragma once
// Cache traces: the lookups and inserts of a render, recorded so that cache backends can be
// replayed and compared without the renderer (bench/cache_replay_bench.cpp). Format, version 2,
// little-endian (docs/cache.md):
//
//   header   char magic[8] = "DOFCTRC\0", u32 version = 2,
//            LookupOptions: f32 max_normal_angle_deg, i32 min_samples, u32 reject_in_front,
//            f32 front_tolerance, f32 footprint_squeeze, f32 footprint_axis[3],
//            f32 camera_position[3], f32 camera_forward[3], f32 floor_per_depth
//            (version 1 ends after front_tolerance: a round footprint)
//   records  u32 tag, u32 count, then count items:
//            tag 1 (lookups): f32 position[3], f32 normal[3]                       (24 bytes each)
//            tag 2 (inserts): f32 position[3], normal[3], value[3], radius, u32 frame (44 bytes)
//            tag 0 (end):     count = 0, last record
//
// A pass is the lookups of one render pass followed by the batch inserted at its end: reading
// groups lookup records into the current pass and closes it at each insert record.
#include <cstdio>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "dofcache/cache/sample.h"

namespace dofcache::cache {

struct TraceLookup {
  glm::vec3 position{0.0f};
  glm::vec3 normal{0.0f, 0.0f, 1.0f};
};

struct TracePass {
  std::vector<TraceLookup> lookups;   // against the cache as it was at the start of the pass
  std::vector<CacheSample> inserts;   // the batch merged at the end of the pass (ids not stored)
};

struct CacheTrace {
  LookupOptions options;
  std::vector<TracePass> passes;

  std::size_t lookup_count() const;
  std::size_t insert_count() const;
};

// Streams a trace to a file as the renderer runs. Throws dofcache::Error on I/O failure.
class TraceWriter {
 public:
  TraceWriter(const std::string& path, const LookupOptions& options);
  ~TraceWriter();  // closes (writing the end record) if close() was not called
  TraceWriter(const TraceWriter&) = delete;
  TraceWriter& operator=(const TraceWriter&) = delete;

  void add_lookups(const std::vector<TraceLookup>& lookups);
  void add_inserts(const std::vector<CacheSample>& batch);
  void close();

 private:
  void write(const void* data, std::size_t bytes);
  std::string path_;
  std::FILE* file_ = nullptr;
};

void write_trace(const std::string& path, const CacheTrace& trace);
// Throws dofcache::Error naming the file and the problem (missing, bad magic or version,
// truncated).
CacheTrace read_trace(const std::string& path);

}  // namespace dofcache::cache
