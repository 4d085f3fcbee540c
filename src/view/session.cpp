#include "dofcache/view/session.h"

#ifdef __linux__
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>
#endif

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <utility>

#include <glm/gtc/matrix_transform.hpp>

#include "dofcache/cache/persistent_cache.h"
#include "dofcache/cache/radiance_cache.h"
#include "dofcache/core/error.h"
#include "dofcache/core/stopwatch.h"
#include "dofcache/core/threads.h"
#include "dofcache/preview/preview_renderer.h"
#include "dofcache/preview/refocus.h"
#include "dofcache/render/camera.h"
#include "dofcache/render/renderer.h"
#include "dofcache/render/setup.h"
#include "dofcache/scene/accel.h"

namespace dofcache::view {
namespace {

using clock = std::chrono::steady_clock;


// The reference's radiance cache is capped (least recently used samples go first).
constexpr std::size_t kReferenceCacheBytes = std::size_t{1} << 30;

// Lowers the calling thread's scheduling priority (Linux: nice is per thread). The background
// renders run on the worker thread itself when they have one thread (two cores), so a click's
// post-process on a server thread preempts them.
void lower_thread_priority() {
#ifdef __linux__
  setpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)), 10);
#endif
}

}  // namespace

const char* input_stage_name(InputStage stage) {
  switch (stage) {
    case InputStage::None: return "none";
    case InputStage::Draft: return "draft";
    case InputStage::Occlusion: return "occlusion";
    case InputStage::Refined: return "refined";
  }
  return "none";
}

std::uint64_t reference_pass_seed(std::uint64_t seed, std::uint64_t pass) {
  return seed + 7919 * pass;
}

void ViewSettings::validate() const {
  if (request.kind != request::Kind::View) throw Error("view: the request must be the viewer's");
  if (request.width < 16 || request.width > 8192)
    throw Error("view: width must be in [16, 8192]");
  if (request.height != 0 && (request.height < 16 || request.height > 8192))
    throw Error("view: height must be in [16, 8192] (or 0: from the camera)");
  if (request.threads < 0) throw Error("view: threads must be >= 0");
  if (input_spp < 1 || input_spp > 4096) throw Error("view: input spp must be in [1, 4096]");
  if (reference_pass_spp < 1 || reference_pass_spp > 4096)
    throw Error("view: reference pass spp must be in [1, 4096]");
  if (reference_max_spp < reference_pass_spp)
    throw Error("view: reference max spp must be at least the pass spp");
  if (request.mode.preview || request.mode.integrator != render::Mode::Drt)
    throw Error("view: the reference is a drt render");
}

struct ViewSession::Render {
  explicit Render(const scene::Scene& scene, const std::string& camera_name)
      : accel(scene), camera(scene.camera_or_first(camera_name)) {}
  scene::Accel accel;
  scene::Camera camera;
};

// The pinhole inputs: what refocus_inputs needs.
struct SavedInputs {
  preview::PreviewInputs inputs;
  preview::RevealedCoverage coverage;
};

struct ViewSession::State {
  lens::ThinLens lens;       // a real lens's thick-lens equivalent
  lens::MountedLens real;    // empty: the thin lens
  preview::PreviewMethod method = preview::PreviewMethod::LayeredOcclusion;
  preview::LayerComposite composite = preview::LayerComposite::Over;
  scene::Camera camera;               // moved by move_camera
  std::uint64_t camera_version = 0;   // the inputs and the reference restart when it changes
  std::uint64_t lens_version = 1;    // the reference restarts when it changes
  std::uint64_t method_version = 0;  // method or composite: only the preview is recomputed
  std::uint64_t last_preview_method_version = 0;

  std::shared_ptr<const SavedInputs> inputs;
  InputStage stage = InputStage::None;
  std::uint64_t inputs_version = 0;
  clock::time_point started;
  double first_preview_ms = -1;
  double last_refocus_ms = -1;
  std::string refocus_warning;
  std::optional<ViewImage> last_preview;
  preview::PreviewWorkspace workspace;

  std::optional<ViewImage> reference;  // for reference_lens_version
  std::uint64_t reference_lens_version = 0;
  std::uint64_t reference_version = 0;
  double reference_seconds = 0;
  bool reference_done = false;
  std::size_t reference_cache_samples = 0;
  double reference_reuse_rate = 0;

  std::string error;
  bool stop = false;
};

ViewSession::ViewSession(scene::Scene scene, const render::LensOverrides& lens,
                         const ViewSettings& settings)
    : scene_(std::make_unique<scene::Scene>(std::move(scene))),
      settings_(settings),
      state_(std::make_unique<State>()) {
  settings_.validate();
  render_ = std::make_unique<Render>(*scene_, settings_.request.camera);
  state_->camera = render_->camera;
  request::RenderRequest q = settings_.request;
  q.lens = lens;
  q.spp = settings_.reference_pass_spp;
  resolved_ = request::resolve(q, *scene_, render_->accel, render_->camera);
  state_->lens = resolved_.settings.lens;
  state_->lens.validate();
  state_->real = resolved_.settings.real_lens;
  real_choices_ = q.lens.real;
  width_ = resolved_.settings.width;
  height_ = resolved_.settings.height;
  options_ = resolved_.preview_options;
  options_.threads = resolve_threads(settings_.request.threads);  // a click's post-process: all
  state_->started = clock::now();
}

ViewSession::~ViewSession() { stop(); }

void ViewSession::start() {
  if (worker_.joinable()) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    state_->started = clock::now();
    state_->stop = false;
  }
  worker_ = std::thread([this] { run_worker(); });
}

void ViewSession::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    state_->stop = true;
  }
  changed_.notify_all();
  if (worker_.joinable()) worker_.join();
}

bool ViewSession::wait_for_inputs(double seconds) {
  return wait_for_stage(InputStage::Draft, seconds);
}

bool ViewSession::wait_for_stage(InputStage stage, double seconds) {
  std::unique_lock<std::mutex> lock(mutex_);
  return changed_.wait_for(lock, std::chrono::duration<double>(seconds), [&] {
    return static_cast<int>(state_->stage) >= static_cast<int>(stage) || !state_->error.empty();
  }) && static_cast<int>(state_->stage) >= static_cast<int>(stage);
}

void ViewSession::run_worker() {
  try {
    bool lowered = false;
    for (;;) {  // once per camera position: the inputs in stages, then the reference
      std::uint64_t camera_version;
      {
        std::lock_guard<std::mutex> lock(mutex_);
        if (state_->stop) return;
        camera_version = state_->camera_version;
      }
      for (InputStage stage : {InputStage::Draft, InputStage::Occlusion, InputStage::Refined}) {
        if (!render_inputs(stage, camera_version)) break;  // stopped, or the camera moved
        if (!lowered) lower_thread_priority();  // after the first draft, the rest is background
        lowered = true;
      }
      if (settings_.reference) refine_reference(camera_version);  // returns when the camera moves
      std::unique_lock<std::mutex> lock(mutex_);
      changed_.wait(lock, [&] { return state_->stop || state_->camera_version != camera_version; });
    }
  } catch (const std::exception& e) {
    std::lock_guard<std::mutex> lock(mutex_);
    state_->error = e.what();
    changed_.notify_all();
  }
}

bool ViewSession::render_inputs(InputStage stage, std::uint64_t camera_version) {
  render::RenderSettings s = resolved_.settings;  // background threads, shading, environment
  s.mode = render::Mode::Pinhole;
  s.progress = Progress::Display::Never;
  s.adaptive.enabled = false;
  s.cache = render::CacheSettings{};
  const bool draft = stage == InputStage::Draft;
  const bool quick = stage != InputStage::Refined;
  s.spp = quick ? preview::kQuickInputSpp : settings_.input_spp;
  if (quick) s.shading = preview::quick_input_shading(resolved_.settings.shading, !draft);
  // The user waits for the draft: it takes every core.
  if (draft) s.threads = resolve_threads(settings_.request.threads);
  if (draft) {  // a quarter of the pixels (rounded up, so the upscale covers every pixel)
    s.width = (width_ + 1) / 2;
    s.height = (height_ + 1) / 2;
  }
  scene::Camera camera;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (state_->stop || state_->camera_version != camera_version) return false;
    s.lens = state_->lens;  // the occlusion fix's layers are planned for the lens of the moment
    s.real_lens = state_->real;  // a real lens: seen from its principal plane, its field of view
    camera = state_->camera;
  }
  const preview::PreviewMethod method =
      draft ? preview::PreviewMethod::Layered : preview::PreviewMethod::LayeredOcclusion;
  preview::SceneInputs p =
      preview::render_preview_inputs(*scene_, render_->accel, camera, s, method, options_);
  if (draft) p.inputs = preview::upscale_inputs(p.inputs, width_, height_);
  auto saved = std::make_shared<SavedInputs>(SavedInputs{std::move(p.inputs), p.coverage});

  std::lock_guard<std::mutex> lock(mutex_);
  if (state_->camera_version != camera_version) return false;  // moved meanwhile: discard
  state_->inputs = std::move(saved);
  state_->stage = stage;
  ++state_->inputs_version;
  if (state_->first_preview_ms < 0) state_->first_preview_ms = ms_since(state_->started);
  changed_.notify_all();
  return true;
}

void ViewSession::refine_reference(std::uint64_t camera_version) {
  // One cache for every lens and camera of the session: each pass is a frame of the persistent
  // cache, whose reuse rule gives every sample the radius the current lens and camera allow
  // (sequence/persistent_cache.h), so a lens change keeps the samples that stay valid.
  const cache::RadiusSettings& radius = resolved_.settings.cache.radius;
  if (!persistent_ && resolved_.cache_backend != cache::kNoCache)
    persistent_ = std::make_unique<cache::PersistentCache>(
        resolved_.cache_backend, cache::ReusePolicy{0, kReferenceCacheBytes}, radius);
  image::Image sum;
  int spp = 0;
  std::uint64_t pass = 0, lens_version = 0;
  lens::ThinLens lens;
  lens::MountedLens real;
  scene::Camera camera;
  for (;;) {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      // Converged: sleep until the lens changes.
      changed_.wait(lock, [&] {
        return state_->stop || state_->lens_version != lens_version ||
               state_->camera_version != camera_version || spp < settings_.reference_max_spp;
      });
      if (state_->stop || state_->camera_version != camera_version) return;
      camera = state_->camera;
      if (state_->lens_version != lens_version) {  // (re)start for the current lens
        lens_version = state_->lens_version;
        lens = state_->lens;
        real = state_->real;
        spp = 0;
        sum = image::Image();
        state_->reference.reset();
        state_->reference_lens_version = lens_version;
        state_->reference_seconds = 0;
        state_->reference_done = false;
        ++state_->reference_version;
      }
    }
    render::RenderSettings s = resolved_.settings;
    s.seed = reference_pass_seed(settings_.request.seed, ++pass);
    s.lens = lens;
    s.real_lens = real;
    s.progress = Progress::Display::Never;
    s.cache.frame = static_cast<std::uint32_t>(pass);
    const auto t0 = clock::now();
    if (persistent_)
      s.cache.cache = persistent_->begin_frame(static_cast<std::int32_t>(pass),
                                               render::make_camera(camera, s).frame_camera());
    render::RenderOutput out = render::render(*scene_, render_->accel, camera, s);
    cache::FrameCacheStats cache_stats;
    if (persistent_) cache_stats = persistent_->end_frame();
    const double seconds = ms_since(t0) * 1e-3;

    if (sum.empty()) sum = image::Image(out.color.width(), out.color.height(), 3, 0.0f);
    std::vector<float>& acc = sum.data();
    const std::vector<float>& add = out.color.data();
    for (std::size_t i = 0; i < acc.size(); ++i) acc[i] += add[i] * float(s.spp);
    spp += s.spp;
    image::Image mean(sum.width(), sum.height(), 3);
    for (std::size_t i = 0; i < acc.size(); ++i) mean.data()[i] = acc[i] / float(spp);

    std::lock_guard<std::mutex> lock(mutex_);
    if (state_->lens_version != lens_version) continue;  // the lens changed meanwhile: discard
    state_->reference = ViewImage{std::move(mean), lens_version, 0, 0, spp};
    state_->reference_cache_samples = cache_stats.samples_at_end;
    state_->reference_reuse_rate = cache_stats.reuse_rate();
    state_->reference_seconds += seconds;
    state_->reference_done = spp >= settings_.reference_max_spp;
    ++state_->reference_version;
    changed_.notify_all();
  }
}

ViewStatus ViewSession::status() const {
  std::lock_guard<std::mutex> lock(mutex_);
  const State& st = *state_;
  ViewStatus s;
  s.width = width_;
  s.height = height_;
  s.lens = st.lens;
  s.real_lens = st.real;
  s.method = st.method;
  s.composite = st.composite;
  s.lens_version = st.lens_version;
  s.camera_version = st.camera_version;
  s.stage = st.stage;
  s.inputs_version = st.inputs_version;
  s.first_preview_ms = st.first_preview_ms;
  s.last_refocus_ms = st.last_refocus_ms;
  s.refocus_warning = st.refocus_warning;
  const bool current = st.reference && st.reference_lens_version == st.lens_version;
  s.reference_spp = current ? st.reference->reference_spp : 0;
  s.reference_version = st.reference_version;
  s.reference_seconds = current ? st.reference_seconds : 0;
  s.reference_done = current && st.reference_done;
  s.reference_cache_samples = st.reference_cache_samples;
  s.reference_reuse_rate = st.reference_reuse_rate;
  s.error = st.error;
  return s;
}

scene::Camera ViewSession::camera() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return state_->camera;
}

scene::Camera ViewSession::move_camera(double yaw, double pitch, double dolly) {
  if (!std::isfinite(yaw) || !std::isfinite(pitch) || !std::isfinite(dolly) ||
      std::abs(yaw) > 2 * M_PI || std::abs(pitch) > M_PI / 2)
    throw Error("camera: yaw must be within a turn, pitch within a quarter turn, all finite");
  std::lock_guard<std::mutex> lock(mutex_);
  State& st = *state_;
  const glm::dmat4 m(st.camera.camera_to_world);
  const glm::dvec3 position(m[3]), forward = -glm::normalize(glm::dvec3(m[2]));
  const double distance = focus_from_camera(st.lens, st.real);  // to the point in focus
  const glm::dvec3 pivot = position + forward * distance;
  // Yaw about the world's up (+Y) through the pivot, pitch about the camera's right axis; the
  // camera keeps looking at the pivot and its distance, then moves `dolly` along its new axis.
  const glm::dvec3 right = glm::normalize(glm::dvec3(m[0]));
  glm::dmat4 turn = glm::rotate(glm::dmat4(1.0), yaw, glm::dvec3(0, 1, 0)) *
                    glm::rotate(glm::dmat4(1.0), pitch, right);
  glm::dmat4 moved = glm::translate(glm::dmat4(1.0), pivot) * turn *
                     glm::translate(glm::dmat4(1.0), -pivot) * m;
  const glm::dvec3 new_forward = -glm::normalize(glm::dvec3(moved[2]));
  if (std::abs(new_forward.y) > 0.999) throw Error("camera: cannot look straight up or down");
  // A dolly stops short of the pivot (keeping a tenth of the distance): the focus stays ahead.
  const double step = std::min(dolly, 0.9 * distance);
  moved[3] += glm::dvec4(new_forward * step, 0.0);
  if (step != 0.0) {  // the pivot stays in focus
    lens::ThinLens focused = st.lens;
    focused.focus_distance -= step;
    if (st.real) {
      st.real = remount(focused);  // may refuse (too close): nothing has changed yet
      focused = st.real.equivalent();
    }
    st.lens = focused;
  }
  scene::Camera camera = st.camera;
  camera.camera_to_world = glm::mat4(moved);
  place_camera(camera);
  return camera;
}

void ViewSession::set_camera(const scene::Camera& camera) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (camera.camera_to_world == state_->camera.camera_to_world && camera.yfov == state_->camera.yfov)
    return;
  place_camera(camera);
}

void ViewSession::place_camera(const scene::Camera& camera) {
  State& st = *state_;
  st.camera = camera;
  ++st.camera_version;
  ++st.lens_version;  // the reference restarts; previews of the old view are stale
  st.stage = InputStage::None;
  changed_.notify_all();
}

lens::ThinLens ViewSession::lens() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return state_->lens;
}

lens::MountedLens ViewSession::mount(const std::string& file, double fstop, double from_sensor,
                                     const lens::ApertureShape& stop) const {
  return lens::mount_lens(lens::read_lens_file(file), file, fstop, from_sensor,
                          real_choices_.sensor, width_, height_,
                          real_choices_.exposure_follows_lens, stop);
}

lens::MountedLens ViewSession::remount(const lens::ThinLens& lens) const {
  const lens::MountedLens& real = state_->real;
  return mount(real.source, lens.fstop, focus_from_camera(lens, real), lens.aperture);
}

void ViewSession::apply_lens(const lens::ThinLens& lens, const lens::MountedLens& real) {
  State& st = *state_;
  // A real lens's pinhole sits at its front principal plane with its paraxial field of view:
  // where either moves, the inputs are seen from elsewhere.
  const bool moved =
      static_cast<bool>(real) != static_cast<bool>(st.real) ||
      (real && (real.yfov() != st.real.yfov() ||
                real.principal_offset() != st.real.principal_offset()));
  if (st.lens == lens && real.lens == st.real.lens) return;
  st.lens = lens;
  st.real = real;
  ++st.lens_version;
  if (moved) {
    ++st.camera_version;
    st.stage = InputStage::None;
  }
  changed_.notify_all();
}

lens::ThinLens ViewSession::set_lens(const lens::ThinLens& lens) {
  lens.validate();
  std::lock_guard<std::mutex> lock(mutex_);
  State& st = *state_;
  if (st.lens == lens) return lens;
  if (!st.real) {
    apply_lens(lens, {});
    return lens;
  }
  const lens::MountedLens real = remount(lens);  // refuses before anything changes
  apply_lens(real.equivalent(), real);
  return st.lens;
}

lens::ThinLens ViewSession::set_real_lens(const std::string& file) {
  std::lock_guard<std::mutex> lock(mutex_);
  State& st = *state_;
  const double from_sensor = focus_from_camera(st.lens, st.real);
  if (file.empty()) {
    if (!st.real) return st.lens;
    lens::ThinLens thin = st.lens;  // the equivalent's focal length, f-number and stop
    thin.aperture.rims = {};        // the real lens's own
    thin.focus_distance = from_sensor;
    thin.validate();
    apply_lens(thin, {});
    return thin;
  }
  lens::MountedLens real = mount(file, 0.0, from_sensor, st.lens.aperture);  // wide open
  if (st.lens.fstop > real.lens->fstop())
    real = mount(file, st.lens.fstop, from_sensor, st.lens.aperture);
  apply_lens(real.equivalent(), real);
  return st.lens;
}

void ViewSession::set_method(preview::PreviewMethod method) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (state_->method == method) return;
  state_->method = method;
  ++state_->method_version;
}

void ViewSession::set_composite(preview::LayerComposite composite) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (state_->composite == composite) return;
  state_->composite = composite;
  ++state_->method_version;
}

double ViewSession::depth_at(int x, int y) const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!state_->inputs) throw Error("no pinhole inputs yet");
  const image::Image& depth = state_->inputs->inputs.depth;
  if (x < 0 || y < 0 || x >= depth.width() || y >= depth.height())
    throw Error("pixel (" + std::to_string(x) + ", " + std::to_string(y) + ") is outside the " +
                std::to_string(depth.width()) + "x" + std::to_string(depth.height()) + " image");
  return depth.at(x, y, 0);
}

lens::ThinLens ViewSession::focus_at(int x, int y) {
  const double d = depth_at(x, y);
  if (!std::isfinite(d))
    throw Error("focus: nothing is seen at pixel (" + std::to_string(x) + ", " +
                std::to_string(y) + ")");
  lens::ThinLens lens = this->lens();
  lens.focus_distance = d;
  return set_lens(lens);  // refuses a surface nearer than the lens can focus
}

lens::ThinLens ViewSession::focus_plane_at(const int (&pixels)[3][2]) {
  lens::ThinLens lens = this->lens();
  glm::dvec3 points[3];
  int width = 0, height = 0;
  double yfov = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!state_->inputs) throw Error("no pinhole inputs yet");
    const preview::PreviewInputs& in = state_->inputs->inputs;
    width = in.depth.width(), height = in.depth.height(), yfov = in.imaging.yfov;
  }
  // The pinhole inputs' camera space: their field of view and the lens's shift.
  const render::ThinLensCamera camera(glm::mat4(1.0f), static_cast<float>(yfov), lens, width,
                                      height);
  for (int k = 0; k < 3; ++k) {
    const int x = pixels[k][0], y = pixels[k][1];
    const double d = depth_at(x, y);
    if (!std::isfinite(d))
      throw Error("plane of focus: nothing is seen at pixel (" + std::to_string(x) + ", " +
                  std::to_string(y) + ")");
    const glm::vec2 s = camera.film_slopes({x + 0.5f, y + 0.5f});
    points[k] = glm::dvec3(s.x * d, s.y * d, d);
  }
  const lens::TiltedFocus f = lens::focus_plane_through(points, lens.focal_length);
  lens.focus_distance = f.focus_distance;
  lens.aperture.tilt_x_deg = f.tilt_x_deg;
  lens.aperture.tilt_y_deg = f.tilt_y_deg;
  return set_lens(lens);  // validates first, so an unusable plane changes nothing
}

std::optional<ViewImage> ViewSession::preview() {
  std::lock_guard<std::mutex> one_at_a_time(refocus_mutex_);
  std::shared_ptr<const SavedInputs> inputs;
  lens::ThinLens lens;
  preview::PreviewMethod method;
  preview::PreviewOptions options = options_;  // with the composite of the moment
  std::uint64_t lens_version, method_version, inputs_version;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const State& st = *state_;
    if (!st.inputs) return std::nullopt;
    if (st.last_preview && st.last_preview->lens_version == st.lens_version &&
        st.last_preview_method_version == st.method_version &&
        st.last_preview->inputs_version == st.inputs_version) {
      ViewImage reused = *st.last_preview;
      reused.refocus_ms = 0;
      return reused;
    }
    inputs = st.inputs;
    lens = st.lens;
    method = st.method;
    options.layer_composite = st.composite;
    lens_version = st.lens_version;
    method_version = st.method_version;
    inputs_version = st.inputs_version;
  }
  const auto t0 = clock::now();
  preview::RefocusedInputs in =
      preview::refocus_inputs(inputs->inputs, inputs->coverage, lens, options);
  // state_->workspace is used only here, under refocus_mutex_.
  image::Image color = preview::render_preview(in.inputs, method, options, state_->workspace);
  ViewImage result{std::move(color), lens_version, inputs_version, ms_since(t0), 0};

  std::lock_guard<std::mutex> lock(mutex_);
  state_->last_refocus_ms = result.refocus_ms;
  state_->refocus_warning =
      method == preview::PreviewMethod::LayeredOcclusion ? in.warning : std::string();
  state_->last_preview = result;
  state_->last_preview_method_version = method_version;
  return result;
}

std::optional<ViewImage> ViewSession::pinhole() const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!state_->inputs) return std::nullopt;
  return ViewImage{state_->inputs->inputs.color, state_->lens_version, state_->inputs_version, 0,
                   0};
}

std::optional<ViewImage> ViewSession::reference() const {
  std::lock_guard<std::mutex> lock(mutex_);
  const State& st = *state_;
  if (!st.reference || st.reference_lens_version != st.lens_version) return std::nullopt;
  return st.reference;
}

std::optional<image::ErrorMetrics> ViewSession::compare() {
  std::optional<ViewImage> ref = reference();
  if (!ref) return std::nullopt;
  std::optional<ViewImage> pre = preview();
  if (!pre || pre->lens_version != ref->lens_version) return std::nullopt;
  return image::compare(pre->color, ref->color);
}

}  // namespace dofcache::view
