#pragma once
// The state behind `dofcache view`: one scene and camera, the current lens, the saved preview
// inputs and the reference refined in the background (docs/view.md).
//
// A background worker renders, in order:
//   1. draft     the pinhole inputs at half the width and height (a quarter of the rays),
//                1 sample per pixel, direct light only, no revealed layers, upscaled to the full
//                size: the first preview (Kraus & Strengert) as soon as possible, on every core;
//   2. occlusion the pinhole render at 1 sample per pixel with a little indirect light, and the
//                near-plane renders and revealed layers, so the occlusion fix applies. From here
//                on the worker runs at a lower priority and leaves a core to the post-process, so
//                the first preview and the clicks are answered while it renders;
//   3. refined   the inputs at ViewSettings::input_spp with full shading;
//   4. reference distributed ray tracing with the radiance cache, in passes of
//                ViewSettings::reference_pass_spp lens samples, accumulated, up to
//                reference_max_spp. A lens change restarts the accumulation (the pass in flight
//                finishes and is discarded) but keeps the radiance cache: every pass is a frame
//                of a cache::PersistentCache, whose reuse rule keeps the samples that stay
//                valid for the new lens (or camera), with the radius it allows them.
// A camera move (move_camera), or a real lens whose principal plane or field of view moves as it
// focuses (set_lens, set_real_lens), starts again from 1. Every preview is the post-process rerun
// on the latest inputs for the current lens (preview::refocus_inputs, preview::render_preview):
// the inputs do not depend on a thin lens.
//
// Thread safety: every public method may be called from any thread at any time.
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "dofcache/image/image.h"
#include "dofcache/image/metrics.h"
#include "dofcache/lens/real_lens.h"
#include "dofcache/lens/thin_lens.h"
#include "dofcache/preview/options.h"
#include "dofcache/preview/preview.h"
#include "dofcache/render/setup.h"
#include "dofcache/request/resolve.h"
#include "dofcache/render/shading.h"
#include "dofcache/scene/scene.h"

namespace dofcache::cache {
class PersistentCache;
}

namespace dofcache::view {

struct ViewSettings {
  // What every front end shares (request/render_request.h): size, camera, seed, threads (the
  // background work under CorePolicy::LeaveOneCore, the draft on every core), shading (of the
  // refined inputs and the reference), environment, the reference's cache and adaptive sampling.
  // Each reference pass renders this request resolved with reference_pass_spp lens samples, the
  // lens of the moment and its own seed, as `render` would.
  request::RenderRequest request = request::default_request(request::Kind::View);
  int input_spp = 4;                // pinhole samples per pixel of the refined inputs
  bool reference = true;            // run the background reference at all
  int reference_pass_spp = 4;       // lens samples per pixel added by each reference pass
  int reference_max_spp = 1024;     // the reference stops refining here

  void validate() const;  // throws dofcache::Error on absurd values
};

// The distance in focus from the camera node, which for a real lens is its sensor: `lens` is then
// its thick-lens equivalent, whose focus distance counts from the front principal plane.
inline double focus_from_camera(const lens::ThinLens& lens, const lens::MountedLens& real) {
  return lens.focus_distance + (real ? real.principal_offset() : 0.0);
}

// The seed of reference pass `pass` (1, 2, ...): each pass its own samples.
std::uint64_t reference_pass_seed(std::uint64_t seed, std::uint64_t pass);

// The inputs' quality so far.
enum class InputStage { None, Draft, Occlusion, Refined };
const char* input_stage_name(InputStage stage);

struct ViewStatus {
  int width = 0, height = 0;
  lens::ThinLens lens;  // a real lens's thick-lens equivalent (what the preview draws)
  lens::MountedLens real_lens;  // empty: the thin lens
  preview::PreviewMethod method = preview::PreviewMethod::LayeredOcclusion;
  preview::LayerComposite composite = preview::LayerComposite::Over;  // layered methods
  std::uint64_t lens_version = 0;     // raised by every lens change (the reference restarts)
  std::uint64_t camera_version = 0;   // raised by every camera move (the inputs restart too)
  InputStage stage = InputStage::None;
  std::uint64_t inputs_version = 0;   // raised whenever new inputs replace the old
  double first_preview_ms = -1;       // session start to the first inputs (-1: not yet)
  double last_refocus_ms = -1;        // the last post-process (refocus and render_preview)
  // Non-empty when the last occlusion-fixed preview's lens needs hidden surfaces the saved
  // revealed layers do not cover (preview::RefocusedInputs::warning): the fix is then partial
  // until the next inputs, rendered for the current lens, arrive.
  std::string refocus_warning;
  int reference_spp = 0;              // lens samples per pixel accumulated for the current lens
  std::uint64_t reference_version = 0;  // raised by every accumulated pass and every restart
  double reference_seconds = 0;       // rendering time spent on the current reference
  bool reference_done = false;
  // The reference's radiance cache after its last pass: samples, and the fraction of that pass's
  // lookups served by samples of earlier passes (after a lens change: of the earlier lens).
  std::size_t reference_cache_samples = 0;
  double reference_reuse_rate = 0;
  std::string error;                  // a background render's failure, if any
};

// A rendered image with the state it was made for.
struct ViewImage {
  image::Image color;  // RGB linear
  std::uint64_t lens_version = 0;
  std::uint64_t inputs_version = 0;
  double refocus_ms = 0;  // preview: the post-process time (0 when served from the last result)
  int reference_spp = 0;  // reference: its lens samples per pixel
};

class ViewSession {
 public:
  // Takes the scene; the request is resolved as for `render` (request::resolve), with `lens`
  // overriding the request's lens. Throws dofcache::Error on invalid settings, an unknown camera
  // or an absurd lens. Nothing is rendered until start().
  ViewSession(scene::Scene scene, const render::LensOverrides& lens, const ViewSettings& settings);
  ~ViewSession();  // stops the worker (waiting for the render in flight)
  ViewSession(const ViewSession&) = delete;
  ViewSession& operator=(const ViewSession&) = delete;

  void start();  // launches the background worker
  void stop();   // asks it to stop and joins it

  // Waits until the first inputs exist (true) or `seconds` pass (false).
  bool wait_for_inputs(double seconds);
  // Waits until the inputs reach `stage` (true) or `seconds` pass (false).
  bool wait_for_stage(InputStage stage, double seconds);

  int width() const { return width_; }
  int height() const { return height_; }
  ViewStatus status() const;
  lens::ThinLens lens() const;

  // Validates and applies a lens; restarts the reference if it changed. Through a real lens its
  // f-number, its focus distance (from the equivalent's front principal plane, where the pinhole
  // inputs are seen from) and its stop's shape mount the lens again (its focal length is the
  // prescription's); where that moves the principal plane or the field of view (the lens
  // breathes), the inputs are rendered again too. Returns the lens applied.
  lens::ThinLens set_lens(const lens::ThinLens& lens);
  // Looks through the real lens `file` (a prescription file or a shipped lens's name: lens/
  // shipped_lenses.h), or the thin lens again (empty), keeping the focus distance from the
  // sensor, the f-number where the lens reaches it (else its widest) and the stop's shape. The
  // inputs are rendered again and the reference restarts. Throws dofcache::Error (one line) for
  // an unreadable table or a lens that cannot focus there, changing nothing.
  lens::ThinLens set_real_lens(const std::string& file);
  scene::Camera camera() const;  // the camera looked through now
  // Orbits the camera about the point in focus on its axis (`yaw` radians about the world's +Y,
  // `pitch` about the camera's right axis), then moves it `dolly` metres along its axis (at most
  // nine tenths of the way to that point, which stays in focus). The inputs are rendered again
  // from the draft on, and the reference restarts. Returns the new camera. Throws
  // dofcache::Error for non-finite or absurd angles, or a view straight up or down.
  scene::Camera move_camera(double yaw, double pitch, double dolly);
  // Puts the camera at `camera`'s pose (e.g. back where it started); nothing if it is there.
  void set_camera(const scene::Camera& camera);
  void set_method(preview::PreviewMethod method);
  void set_composite(preview::LayerComposite composite);  // how layered methods composite
  // Focuses at pixel (x, y): the focus distance becomes the camera-space depth the pinhole inputs
  // see there. Returns the new lens. Throws dofcache::Error if there are no inputs yet, the pixel
  // is outside the image, nothing is seen there, or it is nearer than the focal length allows.
  lens::ThinLens focus_at(int x, int y);
  // Puts the plane of focus through what the pinhole inputs see at three pixels: the focus
  // distance and the tilt of lens::focus_plane_through. Returns the new lens. Throws
  // dofcache::Error (one line) as focus_at, or if the three points span no usable plane.
  lens::ThinLens focus_plane_at(const int (&pixels)[3][2]);
  // The camera-space depth the pinhole inputs see at pixel (x, y) (+inf: nothing). Throws like
  // focus_at if there are no inputs or the pixel is outside the image.
  double depth_at(int x, int y) const;

  // The preview for the current lens and method (computed on demand, the last one reused while
  // nothing changed); nullopt before the first inputs.
  std::optional<ViewImage> preview();
  // The pinhole colour of the latest inputs; nullopt before the first inputs.
  std::optional<ViewImage> pinhole() const;
  // The reference accumulated so far for the current lens; nullopt before its first pass.
  std::optional<ViewImage> reference() const;
  // Preview against reference (image::compare); nullopt until both exist for the current lens.
  std::optional<image::ErrorMetrics> compare();

 private:
  struct State;
  void run_worker();
  // False (nothing published) when stopped or the camera moved before the inputs were done.
  bool render_inputs(InputStage stage, std::uint64_t camera_version);
  void refine_reference(std::uint64_t camera_version);  // returns when the camera moves
  void place_camera(const scene::Camera& camera);        // under mutex_
  // The lens table `file` mounted on the session's sensor with `fstop`, focused `from_sensor`
  // and with `stop` (a mount reuses a kept lens, else builds its pupil table: a fraction of a
  // second).
  lens::MountedLens mount(const std::string& file, double fstop, double from_sensor,
                          const lens::ApertureShape& stop) const;
  // The real lens of the moment mounted again for `lens` (its f-number, focus and stop), under
  // mutex_.
  lens::MountedLens remount(const lens::ThinLens& lens) const;
  // Applies `lens` (and `real`, empty for the thin lens), under mutex_: the reference restarts,
  // and the inputs too where the pinhole's position or field of view changed.
  void apply_lens(const lens::ThinLens& lens, const lens::MountedLens& real);

  std::unique_ptr<scene::Scene> scene_;
  struct Render;
  std::unique_ptr<Render> render_;  // accel and camera
  // The reference's radiance cache (worker thread only), kept across lens changes and moves.
  std::unique_ptr<cache::PersistentCache> persistent_;
  ViewSettings settings_;
  request::ResolvedRequest resolved_;  // the reference's request (spp: one pass)
  lens::RealLensChoices real_choices_;  // the sensor and exposure a real lens is mounted with
  int width_ = 0, height_ = 0;
  preview::PreviewOptions options_;

  mutable std::mutex mutex_;  // guards state_
  std::condition_variable changed_;
  std::unique_ptr<State> state_;
  std::mutex refocus_mutex_;  // one post-process at a time (it uses the whole machine)
  std::thread worker_;
};

}  // namespace dofcache::view
