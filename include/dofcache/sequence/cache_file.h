#pragma once
// Radiance cache files (--cache-in / --cache-out, and the full checkpoints of persistent
// sequences, which a journal extends: checkpoint_journal.h): OpenVDB files written and read with
// openvdb::io::File. Layout (docs/sequence.md):
//
//   file metadata   dofcache.format = "dofcache radiance cache", dofcache.version = 1,
//                   dofcache.scene_hash (16 hex digits), dofcache.scene (source, informational),
//                   dofcache.light_samples / gather_rays / bounces / sample_quality (int32),
//                   dofcache.min_factor (double), dofcache.sample_count (int64),
//                   dofcache.environment_hash (16 hex digits: the environment light's content
//                   hash, 0 for none; absent in files from before environments: none),
//                   dofcache.lens_design (16 hex digits: lens::LensIdentity::design of the lens
//                   the cache was made through) and dofcache.lens (its every parameter, one
//                   line); both absent in files from before lenses were recorded,
//                   checkpoints also: dofcache.sequence_key (16 hex digits), dofcache.first_frame,
//                   dofcache.frame (int32: the last complete frame)
//   grid "samples"  a PointDataGrid, one point per sample, power-of-two voxel size (so positions
//                   round-trip bit for bit), attributes P, N, value (E/pi) (vec3f), radius,
//                   base_radius, view_radius, footprint (float), id, frame, last_used (int32):
//                   a cache::SampleRecord each
//   trailer         24 bytes after the OpenVDB data: "DOFCSUM1", u64 length of the OpenVDB data,
//                   u64 hash of it. Checked before OpenVDB parses anything, so a damaged file is
//                   refused with a message instead of reaching OpenVDB's readers.
//
// A forged file (one sealed with a valid trailer) is walked before OpenVDB reads it: only the
// layout write_cache_file produces passes, every declared length within the file
// (src/sequence/cache_file_layout.h).
//
// OpenVDB stays inside src/sequence/cache_file.cpp.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "dofcache/lens/lens_identity.h"
#include "dofcache/render/renderer.h"
#include "dofcache/scene/scene.h"
#include "dofcache/cache/persistent_cache.h"

namespace dofcache::sequence {

constexpr int kCacheFileVersion = 1;

// What cached values depend on: the scene, the environment light and the settings of the E/pi
// estimator. A cache is reusable only where all of these match. (The radius rule's min_factor is stored but need not
// match: the reuse rule adapts every radius to the current frame.)
struct CacheIdentity {
  std::uint64_t scene_hash = 0;
  int light_samples = 0, gather_rays = 0, bounces = 0, sample_quality = 0;
  std::uint64_t environment_hash = 0;  // Environment::content_hash(), 0 without one

  bool operator==(const CacheIdentity& o) const {
    return scene_hash == o.scene_hash && environment_hash == o.environment_hash &&
           light_samples == o.light_samples &&
           gather_rays == o.gather_rays && bounces == o.bounces &&
           sample_quality == o.sample_quality;
  }
  bool operator!=(const CacheIdentity& o) const { return !(*this == o); }
};

CacheIdentity cache_identity(const scene::Scene& scene, const render::RenderSettings& settings);

struct SequenceCheckpoint {
  std::uint64_t sequence_key = 0;  // hash of everything that determines the frames so far
  int first_frame = 0;
  int frame = 0;  // the last complete frame; the cache is the state after it
};

struct CacheFile {
  CacheIdentity identity;
  std::string scene_source;
  double min_factor = 0.5;
  std::vector<cache::SampleRecord> records;  // increasing id
  std::optional<SequenceCheckpoint> checkpoint;
  // The lens the cache was made through (the last frame's); design 0: not recorded (older files).
  lens::LensIdentity lens;
};

// Writes atomically (temporary file, then rename). Throws dofcache::Error on failure.
void write_cache_file(const std::string& path, const CacheFile& file);

// Sample count a cache file may declare (docs/reliability.md): 2^28 samples are 16 GiB of records,
// beyond any cache a render keeps in memory.
constexpr std::uint64_t kMaxCacheFileSamples = std::uint64_t{1} << 28;

// Throws dofcache::Error (one line naming the file) if it is missing, not a dofcache cache file,
// damaged, of another format version, declares more than `max_samples` samples, or holds invalid
// samples (non-finite values, non-positive radii, duplicate ids, counts that disagree with the
// metadata).
CacheFile read_cache_file(const std::string& path,
                          std::uint64_t max_samples = kMaxCacheFileSamples);

// What every stored sample must be (cache files and checkpoint journals): finite position and
// value, a unit normal (within 1e-3), finite positive radii, a finite footprint >= 0.
bool valid_sample_record(const cache::SampleRecord& record);

// Appends the integrity trailer to the file at `path` (write_cache_file does this after OpenVDB
// has written the file; public so that tests and tools can seal hand-made files).
void append_cache_file_trailer(const std::string& path);

// Throws dofcache::Error naming what differs (scene, or which shading setting) if the file's
// identity is not `expected`.
void check_cache_identity(const CacheFile& file, const CacheIdentity& expected,
                          const std::string& path);

// Throws dofcache::Error, one line with both lenses, if the file records a lens of another design
// than `expected` (lens/lens_identity.h: focal length, f-number and focus may differ). Cached
// values do not depend on the lens, so `any_lens` (--cache-any-lens) accepts any; a file that
// records no lens is accepted.
void check_cache_lens(const CacheFile& file, const lens::LensIdentity& expected,
                      const std::string& path, bool any_lens);

}  // namespace dofcache::sequence
