#include "dofcache/cache/persistent_cache.h"

#include <algorithm>
#include <atomic>
#include <cassert>
#include <chrono>
#include <cmath>
#include <limits>

#include <tbb/enumerable_thread_specific.h>

#include "dofcache/cache/sample_radius.h"
#include "dofcache/core/error.h"
#include "dofcache/core/stopwatch.h"

namespace dofcache::cache {
namespace {


}  // namespace

// A RadianceCache that forwards to a backend and watches the lookups: which samples they accept
// (usage, for eviction) and whether a hit was served by samples older than the frame (reuse).
// Inserts keep going through RadianceCache::insert, so ids are assigned exactly as the backend
// itself would assign them.
class PersistentCache::Tracked final : public RadianceCache {
 public:
  explicit Tracked(std::unique_ptr<RadianceCache> inner) : inner_(std::move(inner)) {}

  // Marks ids below next_id() as "older than the frame", clears the counters and starts noting
  // the samples added from now on.
  void start_frame() {
    first_id_ = next_id();
    added_.clear();
    tracking_ = true;
    used_.reset(new std::atomic<std::uint8_t>[first_id_]);
    for (std::uint32_t i = 0; i < first_id_; ++i) used_[i].store(0, std::memory_order_relaxed);
    counters_.clear();
  }

  // The samples added since start_frame, as stored (ids assigned), in increasing id order (each
  // insert assigns increasing ids to its batch): the frame's new samples, without enumerating the
  // whole cache.
  const std::vector<CacheSample>& added() const { return added_; }
  bool used(std::uint32_t id) const {
    return id < first_id_ && used_[id].load(std::memory_order_relaxed) != 0;
  }
  void totals(std::uint64_t* lookups, std::uint64_t* hits, std::uint64_t* reused) const {
    *lookups = *hits = *reused = 0;
    for (const Counters& c : counters_) {
      *lookups += c.lookups;
      *hits += c.hits;
      *reused += c.reused;
    }
  }

  std::string name() const override { return inner_->name(); }

  bool lookup(glm::vec3 p, glm::vec3 n, const LookupOptions& options,
              LookupResult* out) const override {
    thread_local std::vector<std::uint32_t> ids;
    ids.clear();
    LookupResult r;
    r.accepted_ids = &ids;
    bool hit = inner_->lookup(p, n, options, &r);
    Counters& c = counters_.local();
    ++c.lookups;
    if (hit) {
      ++c.hits;
      if (!ids.empty() && ids.back() < first_id_) ++c.reused;  // ids come in increasing order
      for (std::uint32_t id : ids)
        if (id < first_id_) used_[id].store(1, std::memory_order_relaxed);
    }
    if (out) {
      out->value = r.value;
      out->weight_sum = r.weight_sum;
      out->count = r.count;
      if (out->accepted_ids)
        out->accepted_ids->insert(out->accepted_ids->end(), ids.begin(), ids.end());
    }
    return hit;
  }

  std::size_t size() const override { return inner_->size(); }
  std::size_t memory_bytes() const override { return inner_->memory_bytes(); }
  void for_each_sample(const std::function<void(const CacheSample&)>& fn) const override {
    inner_->for_each_sample(fn);
  }

 protected:
  void add_samples(const std::vector<CacheSample>& samples) override {
    inner_->restore(samples);  // ids already assigned by RadianceCache::insert or restore
    if (tracking_)
      for (const CacheSample& s : samples)
        if (s.id >= first_id_) {
          assert(added_.empty() || s.id > added_.back().id);
          added_.push_back(s);
        }
  }
  void remove_all() override {
    inner_->clear();
    added_.clear();
  }

 private:
  struct Counters {
    std::uint64_t lookups = 0, hits = 0, reused = 0;
  };
  std::unique_ptr<RadianceCache> inner_;
  std::uint32_t first_id_ = 0;
  bool tracking_ = false;
  std::vector<CacheSample> added_;  // since start_frame (inserts are never concurrent)
  std::unique_ptr<std::atomic<std::uint8_t>[]> used_;  // indexed by id < first_id_
  mutable tbb::enumerable_thread_specific<Counters> counters_;
};

void apply_reuse_rule(std::vector<SampleRecord>& records, const FrameCamera& camera,
                      double min_factor, FrameCacheStats* stats) {
  for (SampleRecord& r : records) {
    float radius = reuse_radius(r.origin, r.sample.radius, camera.imaging,
                                       camera.depth(r.sample.position), min_factor);
    if (stats && radius < r.sample.radius) ++stats->shrunk;
    if (stats && radius > r.sample.radius) ++stats->grown;
    r.sample.radius = radius;
  }
}

PersistentCache::PersistentCache(std::string backend, ReusePolicy policy,
                                 RadiusSettings radius)
    : backend_(std::move(backend)), policy_(policy), radius_(radius) {
  check_radiance_cache_backend(backend_, /*allow_none=*/false);
  if (policy_.evict_after < 0) throw Error("--cache-evict-after must be >= 0");
  radius_.validate();
}

PersistentCache::~PersistentCache() = default;

void PersistentCache::assign(std::vector<SampleRecord> records) {
  std::sort(records.begin(), records.end(), [](const SampleRecord& a, const SampleRecord& b) {
    return a.sample.id < b.sample.id;
  });
  for (std::size_t i = 1; i < records.size(); ++i)
    if (records[i].sample.id == records[i - 1].sample.id)
      throw Error("cache: duplicate sample id " + std::to_string(records[i].sample.id));
  records_ = std::move(records);
  live_.reset();
}

std::unique_ptr<PersistentCache::Tracked> PersistentCache::build(
    const std::vector<SampleRecord>& records) const {
  auto t = std::make_unique<Tracked>(make_radiance_cache(backend_));
  std::vector<CacheSample> samples;
  samples.reserve(records.size());
  for (const SampleRecord& r : records) samples.push_back(r.sample);
  t->restore(samples);
  return t;
}

RadianceCache* PersistentCache::begin_frame(std::int32_t frame,
                                                   const FrameCamera& camera) {
  auto t0 = std::chrono::steady_clock::now();
  frame_ = frame;
  camera_ = camera;
  stats_ = FrameCacheStats{};
  apply_reuse_rule(records_, camera, radius_.min_factor, &stats_);
  live_ = build(records_);
  live_->start_frame();
  stats_.samples_at_start = records_.size();
  begin_seconds_ = seconds_since(t0);
  return live_.get();
}

FrameCacheStats PersistentCache::end_frame() {
  auto t0 = std::chrono::steady_clock::now();
  FrameCacheStats& st = stats_;
  live_->totals(&st.lookups, &st.hits, &st.reused);
  for (SampleRecord& r : records_)
    if (live_->used(r.sample.id)) {
      r.last_used = frame_;
      ++st.used;
    }
  for (const CacheSample& s : live_->added()) {
    SampleRecord r;
    r.sample = s;
    r.origin = radius_origin(s.radius, camera_->imaging, camera_->depth(s.position),
                                    radius_.min_factor);
    r.last_used = frame_;
    records_.push_back(r);
    ++st.inserted;
  }
  const std::size_t live_memory = live_->memory_bytes();
  live_.reset();

  if (policy_.evict_after > 0) {
    const std::int64_t limit = static_cast<std::int64_t>(frame_) - policy_.evict_after;
    auto stale = [&](const SampleRecord& r) { return r.last_used <= limit; };
    std::size_t before = records_.size();
    records_.erase(std::remove_if(records_.begin(), records_.end(), stale), records_.end());
    st.evicted_unused = before - records_.size();
  }

  // The memory cap, on the cache as the next frame builds it (fresh from the list, so the
  // measurement is a function of the list alone and resumed runs decide alike). Samples go in
  // least-recently-used order; the number kept is the largest that fits, found by bracketing
  // with secant steps on the measured memory (a few rebuilds; memory is close to affine in the
  // sample count).
  std::size_t memory = live_memory;  // without a cap: before eviction, no rebuild just to measure
  if (policy_.memory_limit > 0) {
    const std::size_t total = records_.size();
    std::vector<std::size_t> order(total);
    for (std::size_t i = 0; i < total; ++i) order[i] = i;
    std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
      const SampleRecord &x = records_[a], &y = records_[b];
      if (x.last_used != y.last_used) return x.last_used < y.last_used;
      if (x.sample.frame != y.sample.frame) return x.sample.frame < y.sample.frame;
      return x.sample.id < y.sample.id;
    });
    // The `keep` most recently used samples, in id order.
    auto newest = [&](std::size_t keep) {
      std::vector<bool> gone(total, false);
      for (std::size_t i = 0; i < total - keep; ++i) gone[order[i]] = true;
      std::vector<SampleRecord> kept;
      kept.reserve(keep);
      for (std::size_t i = 0; i < total; ++i)
        if (!gone[i]) kept.push_back(records_[i]);
      return kept;
    };
    const double limit = static_cast<double>(policy_.memory_limit);
    std::size_t hi = total, lo = 0;                   // hi: does not fit (or is `total`)
    double m_hi = static_cast<double>(build(records_)->memory_bytes()), m_lo = -1.0;
    memory = static_cast<std::size_t>(m_hi);
    if (m_hi > limit) {
      for (int step = 0; step < 8 && hi - lo > std::max<std::size_t>(1, total / 256); ++step) {
        double guess = m_lo < 0.0 ? hi * limit / m_hi  // proportional until lo is measured
                                  : lo + (limit - m_lo) * double(hi - lo) / (m_hi - m_lo);
        if (!std::isfinite(guess)) guess = 0.5 * double(lo + hi);  // flat: bisect
        guess = std::clamp(std::floor(guess * 0.995), double(lo + 1), double(hi - 1));
        auto n = static_cast<std::size_t>(guess);
        double m = static_cast<double>(build(newest(n))->memory_bytes());
        if (m <= limit) {
          lo = n;
          m_lo = m;
        } else {
          hi = n;
          m_hi = m;
        }
      }
      records_ = newest(lo);
      st.evicted_memory = total - lo;
      memory = m_lo >= 0.0 ? static_cast<std::size_t>(m_lo) : build(records_)->memory_bytes();
    }
  }
  st.samples_at_end = records_.size();
  st.memory_bytes = memory;
  st.maintenance_seconds = begin_seconds_ + seconds_since(t0);
  return st;
}

}  // namespace dofcache::cache
