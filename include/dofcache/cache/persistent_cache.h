#pragma once
// A radiance cache carried across the frames of a camera path (paper section 5: "keep the cache
// across frames when the camera moves slightly").
//
// Cache samples hold E/pi, which is view independent, at a world-space point; only their radius
// belongs to the camera that made them (eqs. 4.1, 4.2: a pixel footprint times the circle of
// confusion at the sample's depth). The value computed at p_i is exact at p_i; the radius only
// says how far it may be extrapolated before the error shows in the image. So, per frame:
//
//  1. Reuse rule (begin_frame). Every sample gets the radius cache::reuse_radius gives it for the
//     new camera (cache/sample_radius.h), from the radius it was made with and what that was made
//     of (RadiusOrigin, recorded when the sample entered the cache): it shrinks where the new frame
//     needs denser samples, grows back towards its original radius where the frame is blurrier,
//     and keeps an adaptive widening scaled by the pixel footprint.
//  2. Usage (during the frame). The renderer gets a wrapper of the cache that records, per lookup,
//     which samples were accepted: a lookup all of whose accepted samples predate the frame is a
//     reuse; every accepted sample is marked used.
//  3. Eviction (end_frame). Samples not used in the last `evict_after` frames are removed; then,
//     if the cache's memory exceeds `memory_limit`, the least recently used are removed first
//     (ties: oldest creation frame, then lowest id) until it fits.
//
// Determinism: the cache the renderer reads in a frame is always built afresh from the list of
// samples (in id order), so a cache loaded from a checkpoint renders exactly the frames the
// uninterrupted run renders, and the memory measured for the cap is a function of that list.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "dofcache/cache/frame_camera.h"
#include "dofcache/cache/radiance_cache.h"
#include "dofcache/cache/sample_radius.h"

namespace dofcache::cache {

// One cached sample and its history across frames.
struct SampleRecord {
  CacheSample sample;  // radius: the radius in effect after the last frame's reuse rule
  RadiusOrigin origin;  // the radius it was made with, and of what
  std::int32_t last_used = 0;  // last frame whose lookups accepted it (or that created it)
};

struct ReusePolicy {
  int evict_after = 8;           // evict samples unused for this many frames (0: never)
  std::size_t memory_limit = 0;  // bytes of RadianceCache::memory_bytes(); 0: no cap
};

// What happened to the cache in one frame.
struct FrameCacheStats {
  std::size_t samples_at_start = 0;  // after the reuse rule
  std::size_t shrunk = 0;            // radii reduced by the reuse rule
  std::size_t grown = 0;             // radii grown back towards their base radius
  std::uint64_t lookups = 0;         // cache lookups by the renderer
  std::uint64_t hits = 0;            // lookups the cache served
  std::uint64_t reused = 0;          // hits whose accepted samples all predate this frame
  std::size_t inserted = 0;          // samples created in this frame
  std::size_t used = 0;              // older samples accepted by at least one lookup
  std::size_t evicted_unused = 0;
  std::size_t evicted_memory = 0;
  std::size_t samples_at_end = 0;
  // At the end of the frame: after eviction with a memory cap, before eviction without one.
  std::size_t memory_bytes = 0;
  double maintenance_seconds = 0.0;  // reuse rule, rebuilds and eviction

  double reuse_rate() const { return lookups ? double(reused) / double(lookups) : 0.0; }
  double hit_rate() const { return lookups ? double(hits) / double(lookups) : 0.0; }
};

// The reuse rule (step 1) on a list of samples for a frame seen by `camera`: what begin_frame
// does to the cache's radii, and what replaying a checkpoint journal does to a loaded list
// (checkpoint_journal.h). Counts the radii shrunk and grown into `stats` if given.
void apply_reuse_rule(std::vector<SampleRecord>& records, const FrameCamera& camera,
                      double min_factor, FrameCacheStats* stats = nullptr);

class PersistentCache {
 public:
  // `backend`: "octree" or "vdb". `radius`: the rule the renderer makes samples with
  // (CacheSettings::radius). Throws dofcache::Error for a bad backend or policy.
  PersistentCache(std::string backend, ReusePolicy policy, RadiusSettings radius = {});
  ~PersistentCache();
  PersistentCache(const PersistentCache&) = delete;
  PersistentCache& operator=(const PersistentCache&) = delete;

  // Replaces the contents (a loaded cache file or checkpoint). Ids must be unique.
  void assign(std::vector<SampleRecord> records);
  void clear() { assign({}); }
  // Every sample with its history, in increasing id.
  const std::vector<SampleRecord>& records() const { return records_; }
  std::size_t size() const { return records_.size(); }

  // Starts frame `frame` seen by `camera`: applies the reuse rule and builds the cache the
  // renderer reads (valid until end_frame). Samples the renderer inserts are stamped by it with
  // CacheSettings::frame, which should be `frame`.
  RadianceCache* begin_frame(std::int32_t frame, const FrameCamera& camera);

  // Ends the frame: records usage, adds the new samples, evicts.
  FrameCacheStats end_frame();

  const ReusePolicy& policy() const { return policy_; }
  const RadiusSettings& radius_settings() const { return radius_; }
  const std::string& backend() const { return backend_; }

  // The wrapper handed to the renderer (public for tests).
  class Tracked;

 private:
  std::unique_ptr<Tracked> build(const std::vector<SampleRecord>& records) const;

  std::string backend_;
  ReusePolicy policy_;
  RadiusSettings radius_;
  std::vector<SampleRecord> records_;  // increasing id
  std::unique_ptr<Tracked> live_;      // during a frame
  std::int32_t frame_ = 0;
  std::optional<FrameCamera> camera_;  // of the current frame
  FrameCacheStats stats_;
  double begin_seconds_ = 0.0;
};

}  // namespace dofcache::cache
