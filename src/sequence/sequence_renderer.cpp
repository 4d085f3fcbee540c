#include "dofcache/sequence/sequence_renderer.h"

#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <optional>

#include "dofcache/cache/radiance_cache.h"
#include "dofcache/core/atomic_file.h"
#include "dofcache/core/content_hash.h"
#include "dofcache/core/error.h"
#include "dofcache/core/progress.h"
#include "dofcache/core/rng.h"
#include "dofcache/core/stopwatch.h"
#include "dofcache/image/image_io.h"
#include "dofcache/request/image_render.h"
#include "dofcache/sequence/cache_file.h"
#include "dofcache/sequence/checkpoint_store.h"

namespace dofcache::sequence {
namespace {

namespace fs = std::filesystem;

// Seed of the sequence key and the records hash ("sequence"); floats hash as the doubles they
// equal (ContentHasher::add(float)).
constexpr std::uint64_t kSequenceHashSeed = 0x73657175656e6365ULL;

double cpu_seconds() {
  timespec t{};
  ::clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

// The render settings of one frame (its lens, seed and cache frame; no cache attached yet).
render::RenderSettings frame_settings(const SequenceSettings& s, const FrameSpec& spec) {
  render::RenderSettings rs = s.render;
  rs.lens = spec.lens;
  rs.real_lens = spec.real_lens;
  rs.seed = frame_seed(s.render.seed, spec.number);
  // The lens pattern stays from frame to frame; the shading draws anew.
  rs.pattern_seed = s.render.pattern_seed.value_or(s.render.seed);
  rs.progress = Progress::Display::Never;
  rs.cache.frame = static_cast<std::uint32_t>(spec.number);
  rs.cache.cache = nullptr;
  return rs;
}

std::uint64_t work_of(const render::RenderSettings& s) {
  return static_cast<std::uint64_t>(s.width) * static_cast<std::uint64_t>(s.height) *
         static_cast<std::uint64_t>(s.visibility_only ? 1 : s.spp);
}

// The lens a cache file records for a frame (lens/lens_identity.h).
lens::LensIdentity frame_lens(const FrameSpec& f) { return lens::lens_identity(f.lens, f.real_lens); }

}  // namespace

const char* cache_mode_name(CacheMode mode) {
  switch (mode) {
    case CacheMode::None: return "none";
    case CacheMode::Fresh: return "fresh";
    case CacheMode::Persistent: return "persistent";
  }
  return "?";
}

std::uint64_t frame_seed(std::uint64_t seed, int frame) {
  return hash_combine(seed, static_cast<std::uint64_t>(static_cast<std::int64_t>(frame)));
}

std::string frame_path(const std::string& pattern, int frame) {
  fs::path p(pattern);
  std::string name = p.filename().string();
  std::size_t first = name.find('#');
  if (first == std::string::npos)
    throw Error("output pattern '" + pattern + "' needs a run of '#' for the frame number, "
                "e.g. 'frames/####.exr'");
  std::size_t last = name.find_first_not_of('#', first);
  if (last == std::string::npos) last = name.size();
  if (name.find('#', last) != std::string::npos)
    throw Error("output pattern '" + pattern + "' has more than one run of '#'");
  std::string number = std::to_string(frame);
  std::size_t width = last - first;
  if (number.size() < width) number.insert(0, width - number.size(), '0');
  name.replace(first, last - first, number);
  return (p.parent_path() / name).string();
}

std::string default_checkpoint_path(const std::string& pattern) {
  fs::path p(pattern);
  return (p.parent_path() / ("." + p.filename().string() + ".checkpoint.vdb")).string();
}

bool frame_complete(const std::string& path, int width, int height) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return false;
  try {
    image::Image im = image::read_image(path);
    return im.width() == width && im.height() == height;
  } catch (const Error&) {
    return false;
  }
}

std::pair<int, int> parse_frame_range(const std::string& text) {
  auto bad = [&]() -> Error {
    return Error("frame range '" + text + "' must be A-B or A (frame numbers >= 0, A <= B)");
  };
  auto number = [&](const std::string& s) {
    if (s.empty() || s.size() > 9 || s.find_first_not_of("0123456789") != std::string::npos)
      throw bad();
    return std::stoi(s);
  };
  std::size_t dash = text.find('-');
  int a = number(text.substr(0, dash));
  int b = dash == std::string::npos ? a : number(text.substr(dash + 1));
  if (b < a) throw bad();
  return {a, b};
}

std::uint64_t records_hash(const std::vector<cache::SampleRecord>& records) {
  ContentHasher h(kSequenceHashSeed);
  h.add(static_cast<std::uint64_t>(records.size()));
  for (const cache::SampleRecord& r : records) {
    const cache::CacheSample& s = r.sample;
    for (int k = 0; k < 3; ++k) {
      h.add(s.position[k]);
      h.add(s.normal[k]);
      h.add(s.value[k]);
    }
    h.add(s.radius);
    h.add(r.origin.radius);
    h.add(r.origin.view_radius);
    h.add(r.origin.footprint);
    h.add(static_cast<std::uint64_t>(s.id) << 32 | s.frame);
    h.add(static_cast<int>(r.last_used));
  }
  return h.value();
}

std::uint64_t sequence_key(const scene::Scene& scene, const SequenceSettings& settings,
                           const std::vector<FrameSpec>& frames, std::size_t count,
                           std::uint64_t initial_cache_hash) {
  const render::RenderSettings& r = settings.render;
  ContentHasher h(kSequenceHashSeed);
  // 2: the frames share their pixels' lens patterns (RenderSettings::pattern_seed).
  h.add(std::string("dofcache sequence 2"));
  h.add(scene.content_hash);
  h.add(r.width), h.add(r.height), h.add(r.spp), h.add(static_cast<int>(r.mode));
  h.add(r.seed), h.add(r.pattern_seed.value_or(r.seed));
  h.add(r.shading.light_samples), h.add(r.shading.gather_rays), h.add(r.shading.bounces);
  h.add(r.shading.specular_depth), h.add(r.shading.rough_lobe_rate);
  // Added only when set, so that the keys of checkpoints made before it existed still match.
  if (r.shading.material_override != render::MaterialOverride::None)
    h.add(static_cast<std::int32_t>(r.shading.material_override));
  // Only with an environment, so that the keys of sequences without one stay as they were.
  if (r.shading.environment) h.add(r.shading.environment->content_hash());
  h.add(r.near_depth);
  h.add(static_cast<int>(settings.cache_mode));
  h.add(settings.cache_backend);
  h.add(r.cache.radius.min_factor), h.add(render::effective_sample_quality(r));
  h.add(static_cast<int>(r.cache.radius.rule)), h.add(r.cache.radius.accuracy);
  h.add(r.cache.radius.max_radius_pixels);
  h.add(r.cache.lookup.max_normal_angle_deg), h.add(r.cache.lookup.min_samples);
  h.add(r.cache.lookup.reject_in_front), h.add(r.cache.lookup.front_tolerance);
  h.add(settings.evict_after), h.add(settings.cache_memory_mb);
  h.add(initial_cache_hash);
  for (std::size_t i = 0; i < count && i < frames.size(); ++i) {
    const FrameSpec& f = frames[i];
    h.add(f.number);
    for (int c = 0; c < 4; ++c)
      for (int k = 0; k < 4; ++k) h.add(f.camera.camera_to_world[c][k]);
    h.add(f.camera.yfov);
    h.add(f.lens.focal_length), h.add(f.lens.fstop), h.add(f.lens.focus_distance);
    const lens::ApertureShape& a = f.lens.aperture;
    if (!a.round())  // a round aperture keeps the keys of runs made before shapes existed
      h.add(a.blades), h.add(a.rotation_deg), h.add(a.roundness), h.add(a.anamorphic_ratio);
    // Since the cache's footprint follows an oval bokeh, an anamorphic run's samples differ.
    if (a.anamorphic_ratio != 1.0) h.add(std::string("oval footprint"));
    if (a.vignetting()) h.add(a.stop.radius), h.add(a.stop.distance);
    if (a.chromatic()) h.add(a.axial_ca), h.add(a.lateral_ca);
    if (a.weighted()) h.add(static_cast<int>(a.profile)), h.add(a.profile_strength);
    if (a.tilted()) h.add(a.tilt_x_deg), h.add(a.tilt_y_deg);
    if (a.shifted()) h.add(a.shift_x), h.add(a.shift_y);
    if (!a.image.empty()) h.add(a.image);
    if (const lens::MountedLens& m = f.real_lens) {  // the prescription, the film and the exposure
      for (const lens::LensSurface& s : m.lens->surfaces())
        h.add(s.radius), h.add(s.thickness), h.add(s.ior), h.add(s.aperture_diameter), h.add(s.abbe);
      h.add(m.film_size.x), h.add(m.film_size.y), h.add(m.lens->focus_distance());
      h.add(static_cast<int>(m.lens->exposure_follows_lens()));
    }
  }
  return h.value();
}

void SequenceSettings::validate() const {
  if (!output.empty()) frame_path(output, 0);
  if (evict_after < 0) throw Error("--cache-evict-after must be >= 0");
  if (!(cache_memory_mb >= 0.0) || !std::isfinite(cache_memory_mb))
    throw Error("--cache-memory must be a number of MB >= 0");
  if (!(checkpoint_journal_ratio >= 0.0) || !std::isfinite(checkpoint_journal_ratio))
    throw Error("--checkpoint-journal must be a number >= 0");
  if (cache_mode != CacheMode::None) {
    cache::check_radiance_cache_backend(cache_backend, /*allow_none=*/false);
    if (render.mode == render::Mode::Pinhole)
      throw Error("the radiance cache applies to drt and accumulation renders, not pinhole");
  } else if (!cache_in.empty() || !cache_out.empty()) {
    throw Error("--cache-in and --cache-out need a cache (--cache octree or vdb)");
  }
  // Cache files record the shading their values depend on, but not this benchmark mode: refused
  // rather than mixed with files made without it. (Checkpoints are keyed by sequence_key.)
  if (render.shading.material_override != render::MaterialOverride::None &&
      (!cache_in.empty() || !cache_out.empty()))
    throw Error("--cache-in and --cache-out do not record --material-override; render without "
                "cache files");
  if (temporal_window < 0 || temporal_window > request::kMaxTemporalWindow)
    throw Error("--temporal must be 0 to " + std::to_string(request::kMaxTemporalWindow) +
                " frames on each side");
  if (temporal_window > 0) {
    if (output.empty() || !image::is_exr_path(output) || !render.lens_features)
      throw Error("--temporal filters denoised EXR frames (--out frames/####.exr --denoise on)");
    frame_path(temporal_output, 0);
    if (temporal_output == output)
      throw Error("--temporal-output must differ from --out: the filter reads the frames there");
  }
  render::RenderSettings r = render;
  r.cache.cache = nullptr;
  r.validate();
}

SequenceRenderer::SequenceRenderer(const scene::Scene& scene, const scene::Accel& accel,
                                   std::vector<FrameSpec> frames, SequenceSettings settings)
    : scene_(scene), accel_(accel), frames_(std::move(frames)), settings_(std::move(settings)) {
  settings_.validate();
  if (frames_.empty()) throw Error("the sequence has no frames");
  for (std::size_t i = 1; i < frames_.size(); ++i)
    if (frames_[i].number <= frames_[i - 1].number)
      throw Error("sequence frames must be in increasing frame number");
  // The reuse rule adapts kept samples' radii to each frame's planes of focus along the axis
  // (cache/sample_radius.h); a tilted plane it does not know yet.
  if (settings_.cache_mode == CacheMode::Persistent)
    for (const FrameSpec& f : frames_)
      if (f.lens.aperture.tilted())
        throw Error("--persistent does not follow a tilted lens yet (frame " +
                    std::to_string(f.number) + "): render with a fresh cache per frame "
                    "(--cache vdb without --persistent)");
  checkpoint_ = settings_.checkpoint;
  if (checkpoint_.empty() && settings_.cache_mode == CacheMode::Persistent &&
      !settings_.output.empty())
    checkpoint_ = default_checkpoint_path(settings_.output);
}

std::size_t SequenceRenderer::replay_journal(const CheckpointJournal& journal, std::size_t at,
                                             const std::vector<std::string>& paths,
                                             std::uint64_t initial_hash,
                                             std::vector<cache::SampleRecord>& records,
                                             std::string* why) const {
  const std::size_t n = frames_.size();
  const double min_factor = settings_.render.cache.radius.min_factor;
  std::size_t replayed = 0;
  why->clear();
  for (const JournalRecord& r : journal.records) {
    const std::size_t i = at + replayed + 1;
    if (i >= n) return replayed;  // the journal goes on past this run's last frame
    const FrameSpec& spec = frames_[i];
    const std::string frame = "frame " + std::to_string(r.frame);
    if (r.frame != spec.number) {
      *why = "its record after frame " + std::to_string(frames_[i - 1].number) + " is for frame " +
             std::to_string(r.frame) + ", this run's next is " + std::to_string(spec.number);
      return replayed;
    }
    if (r.sequence_key != sequence_key(scene_, settings_, frames_, i + 1, initial_hash)) {
      *why = frame + " was made with another camera or lens";
      return replayed;
    }
    if (!frame_complete(paths[i], settings_.render.width, settings_.render.height)) {
      *why = frame + " (" + paths[i] + ") is missing or unreadable";
      return replayed;
    }
    // The frame's reuse rule, then its recorded changes, on a copy: a record that does not fit
    // leaves the cache as the previous one made it.
    std::vector<cache::SampleRecord> next = records;
    cache::apply_reuse_rule(next, render::make_camera(spec.camera, frame_settings(settings_, spec)).frame_camera(),
                     min_factor);
    try {
      apply_frame_delta(next, r.delta, r.frame);
    } catch (const Error& e) {
      *why = frame + ": " + e.what();
      return replayed;
    }
    if (state_hash(next) != r.state_hash) {
      *why = "replaying " + frame + " does not reproduce the cache it recorded";
      return replayed;
    }
    records = std::move(next);
    ++replayed;
  }
  if (!journal.tail.empty()) *why = journal.tail;
  return replayed;
}

SequenceSummary SequenceRenderer::run(const FrameCallback& on_frame,
                                      const NoticeCallback& notice) {
  auto start = std::chrono::steady_clock::now();
  auto say = [&](const std::string& text) {
    if (notice) notice(text);
  };
  const SequenceSettings& s = settings_;
  const CacheIdentity identity = cache_identity(scene_, s.render);
  const int width = s.render.width, height = s.render.height;
  const std::size_t n = frames_.size();
  std::vector<std::string> paths(n);
  if (!s.output.empty()) {
    for (std::size_t i = 0; i < n; ++i) paths[i] = frame_path(s.output, frames_[i].number);
    fs::path dir = fs::path(paths[0]).parent_path();
    std::error_code ec;
    if (!dir.empty()) fs::create_directories(dir, ec);
    image::check_output_path(paths[0]);
    std::vector<std::string> targets = paths;
    targets.push_back(checkpoint_);
    if (!checkpoint_.empty()) targets.push_back(checkpoint_journal_path(checkpoint_));
    remove_stale_temporaries(targets);
  }

  // The initial cache: --cache-in, its samples counted as last used just before the first frame.
  std::vector<cache::SampleRecord> initial;
  if (!s.cache_in.empty()) {
    CacheFile in = read_cache_file(s.cache_in);
    check_cache_identity(in, identity, s.cache_in);
    check_cache_lens(in, frame_lens(frames_.front()), s.cache_in, s.cache_any_lens);
    initial = std::move(in.records);
    for (cache::SampleRecord& r : initial) r.last_used = frames_.front().number - 1;
    say("loaded " + std::to_string(initial.size()) + " cache samples from " + s.cache_in);
  }
  const std::uint64_t initial_hash = records_hash(initial);
  if (s.cache_mode != CacheMode::None) {
    cache::ReusePolicy policy;
    policy.evict_after = s.evict_after;
    policy.memory_limit = static_cast<std::size_t>(s.cache_memory_mb * 1e6);
    cache_ = std::make_unique<cache::PersistentCache>(s.cache_backend, policy, s.render.cache.radius);
    cache_->assign(initial);
  }

  std::optional<CheckpointStore> store;
  if (s.cache_mode == CacheMode::Persistent && !checkpoint_.empty()) {
    CacheFile header;
    header.identity = identity;
    header.scene_source = scene_.source;
    header.min_factor = s.render.cache.radius.min_factor;
    store.emplace(checkpoint_, std::move(header), s.checkpoint_journal_ratio);
  }

  // What is complete already.
  std::vector<bool> skip(n, false);
  SequenceSummary summary;
  if (s.resume && !s.output.empty()) {
    if (s.cache_mode == CacheMode::Persistent) {
      std::error_code ec;
      if (!checkpoint_.empty() && fs::exists(checkpoint_, ec)) {
        try {
          CacheFile cp = read_cache_file(checkpoint_);
          if (!cp.checkpoint) throw Error("it is a cache file, not a sequence checkpoint");
          check_cache_identity(cp, identity, checkpoint_);
          if (cp.checkpoint->first_frame != frames_.front().number)
            throw Error("it belongs to a sequence starting at frame " +
                        std::to_string(cp.checkpoint->first_frame));
          std::size_t at = n;
          for (std::size_t i = 0; i < n; ++i)
            if (frames_[i].number == cp.checkpoint->frame) at = i;
          if (at == n)
            throw Error("its frame " + std::to_string(cp.checkpoint->frame) +
                        " is not in this sequence");
          if (cp.checkpoint->sequence_key != sequence_key(scene_, s, frames_, at + 1, initial_hash))
            throw Error("it was made with other settings, camera path or initial cache");
          for (std::size_t i = 0; i <= at; ++i)
            if (!frame_complete(paths[i], width, height))
              throw Error("frame " + std::to_string(frames_[i].number) + " (" + paths[i] +
                          ") is missing or unreadable");
          std::size_t replayed = 0;
          const std::string journal_path = checkpoint_journal_path(checkpoint_);
          if (fs::exists(journal_path, ec)) {
            // A journal that is unreadable or extends another base is not used: the run goes on
            // from the base alone, and its next frame writes a new base.
            std::optional<CheckpointJournal> journal;
            const std::uint64_t base_bytes = fs::file_size(checkpoint_, ec);
            try {
              journal = read_checkpoint_journal(journal_path);
              const JournalBase& b = journal->base;
              if (b.sequence_key != cp.checkpoint->sequence_key ||
                  b.frame != cp.checkpoint->frame || b.state_hash != state_hash(cp.records))
                throw Error(journal_path + ": it extends another checkpoint than " + checkpoint_ +
                            " (one after frame " + std::to_string(b.frame) + ")");
              if (ec) throw Error(checkpoint_ + ": " + ec.message());
            } catch (const Error& e) {
              std::string reason = e.what();
              if (reason.rfind(journal_path + ": ", 0) == 0)
                reason = reason.substr(journal_path.size() + 2);
              journal.reset();
              say("not using checkpoint journal " + journal_path + ": " + reason +
                  "; resuming from the full checkpoint alone");
            }
            if (journal) {
              std::string why;
              replayed = replay_journal(*journal, at, paths, initial_hash, cp.records, &why);
              store->continue_journal(base_bytes, replayed ? journal->ends[replayed - 1]
                                                           : kJournalHeaderBytes);
              if (!why.empty())
                say("checkpoint journal " + journal_path + ": " + why + "; resuming after frame " +
                    std::to_string(frames_[at + replayed].number));
            }
          }
          at += replayed;
          cache_->assign(std::move(cp.records));
          for (std::size_t i = 0; i <= at; ++i) skip[i] = true;
          summary.resumed_after = frames_[at].number;
          summary.journal_records_replayed = static_cast<int>(replayed);
          say("resuming after frame " + std::to_string(frames_[at].number) + " (checkpoint " +
              checkpoint_ +
              (replayed ? " and " + std::to_string(replayed) + " journal records" : "") + ", " +
              std::to_string(cache_->size()) + " cache samples)");
        } catch (const Error& e) {
          std::string why = e.what();
          if (why.rfind(checkpoint_ + ": ", 0) == 0) why = why.substr(checkpoint_.size() + 2);
          say("not resuming from checkpoint " + checkpoint_ + ": " + why +
              "; rendering from frame " + std::to_string(frames_.front().number));
          cache_->assign(initial);
        }
      } else if (std::any_of(paths.begin(), paths.end(), [&](const std::string& p) {
                   std::error_code e;
                   return fs::exists(p, e);
                 })) {
        say("no checkpoint (" + checkpoint_ + "): rendering every frame from frame " +
            std::to_string(frames_.front().number) + ", since each depends on the ones before");
      }
    } else {
      for (std::size_t i = 0; i < n; ++i) skip[i] = frame_complete(paths[i], width, height);
      std::size_t done = static_cast<std::size_t>(std::count(skip.begin(), skip.end(), true));
      if (done > 0)
        say(std::to_string(done) + " of " + std::to_string(n) +
            " frames are complete already; rendering the others");
    }
  }

  std::uint64_t total = 0;
  for (std::size_t i = 0; i < n; ++i)
    if (!skip[i]) total += work_of(s.render);
  Progress progress("sequence", total, s.render.progress);

  for (std::size_t i = 0; i < n; ++i) {
    const FrameSpec& spec = frames_[i];
    FrameReport rep;
    rep.frame = spec.number;
    rep.spec = spec;
    rep.index = static_cast<int>(i);
    rep.count = static_cast<int>(n);
    rep.path = paths[i];
    if (skip[i]) {
      rep.skipped = true;
      ++summary.skipped;
      if (on_frame) on_frame(rep);
      continue;
    }
    progress.set_label("frame " + std::to_string(spec.number) + " (" + std::to_string(i + 1) +
                       "/" + std::to_string(n) + ")");
    render::RenderSettings rs = frame_settings(s, spec);
    std::vector<cache::SampleRecord> before;  // the cache after the reuse rule, for the journal
    double before_seconds = 0.0, before_cpu = 0.0;
    if (cache_) {
      if (s.cache_mode == CacheMode::Fresh) cache_->assign(initial);
      rs.cache.cache = cache_->begin_frame(spec.number, render::make_camera(spec.camera, rs).frame_camera());
      if (store && store->journaling()) {
        auto t = std::chrono::steady_clock::now();
        const double cpu = cpu_seconds();
        before = cache_->records();
        before_cpu = cpu_seconds() - cpu;
        before_seconds = seconds_since(t);
      }
    }
    rep.output = render::render(scene_, accel_, spec.camera, rs);
    rep.render_seconds = rep.output.stats.seconds;
    if (cache_) {
      rep.cache = cache_->end_frame();
      rep.cache_seconds = rep.cache.maintenance_seconds;
    }
    if (rs.lens_features) {  // --denoise: each frame by the render's filter (request::denoised)
      const Stopwatch clock;
      rep.denoised = request::denoised(rep.output, rs, spec.camera);
      rep.denoise_seconds = clock.seconds();
    }
    auto t_write = std::chrono::steady_clock::now();
    if (!rep.path.empty()) request::write_render(rep.path, rep.output, rep.denoised);
    if (store) {
      auto t_checkpoint = std::chrono::steady_clock::now();
      const double cpu = cpu_seconds();
      store->set_lens(frame_lens(spec));
      CheckpointStore::Saved saved = store->save(
          cache_->records(), store->journaling() ? &before : nullptr,
          SequenceCheckpoint{sequence_key(scene_, s, frames_, i + 1, initial_hash),
                             frames_.front().number, spec.number});
      rep.checkpoint_bytes = saved.bytes;
      rep.checkpoint_full = saved.base;
      rep.checkpoint_cpu_seconds = cpu_seconds() - cpu + before_cpu;
      rep.checkpoint_seconds = seconds_since(t_checkpoint) + before_seconds;
    }
    rep.write_seconds = seconds_since(t_write);
    ++summary.rendered;
    if (s.cache_mode != CacheMode::None && i > 0) {
      summary.reuse_sum += rep.cache.reuse_rate();
      ++summary.reuse_frames;
    }
    progress.advance(work_of(s.render));
    if (on_frame) on_frame(rep);
  }
  progress.finish();

  if (!s.cache_out.empty() && cache_) {
    if (s.cache_mode == CacheMode::Fresh && summary.rendered == 0) {
      say("no frame was rendered, so there is no cache to write to " + s.cache_out);
    } else {
      CacheFile out;
      out.identity = identity;
      out.scene_source = scene_.source;
      out.min_factor = s.render.cache.radius.min_factor;
      out.records = cache_->records();
      out.lens = frame_lens(frames_.back());
      write_cache_file(s.cache_out, out);
    }
  }
  summary.seconds = seconds_since(start);
  return summary;
}

}  // namespace dofcache::sequence
