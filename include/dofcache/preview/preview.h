#pragma once
// Depth-of-field preview by post-processing one pinhole render (paper section 3): the single entry
// point over the four methods. Pipeline and measured costs: docs/preview.md.
//
// Layered (Kraus & Strengert 2007, paper 3.1), for every layer i = n-1 .. 0 (back to front):
//   1. culling: pixels with signed CoC c < c_{i-2} are foreground for layer i;
//   2. disocclusion: their colour and CoC are filled by normalised pull-push (pull_push.h);
//   3. matting: colour and alpha multiplied by w_i(c) (layers.h);
//   4. blurring: pyramid blur of premultiplied colour and alpha with radius r_i (pyramid.h);
//   5. blending: "over" onto the layers behind; the final image is divided by its total alpha
//      (exactly 1 wherever the blurred mattes add up; elsewhere it removes the residual darkening).
// LayeredOcclusion (paper 3.2) replaces step 2 for the culled pixels that a revealed layer covers:
// the colour and depth come from A_{n-1}, then A_{n-2}, ..., down to A_{max(i-1, 1)} (each
// nearer one overwrites, so the nearest revealed surface at depth >= z_{i-1} wins; that is the
// plateau slab [z_{i-1}, z_i) of layer i and everything behind it), and those fragments are matted
// with revealed_matting_weight (hard front cut). Pull-push fills only what stays unfilled.
// (The paper says "down to A_i"; with the matting indices of 3.1 that would drop the hidden
// surfaces of layer i's own plateau slab, A_{i-1}.)
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "dofcache/image/image.h"
#include "dofcache/lens/thin_lens.h"
#include "dofcache/preview/layers.h"
#include "dofcache/preview/options.h"

namespace dofcache::preview {

enum class PreviewMethod { Gather, Scatter, Layered, LayeredOcclusion };

// The methods' one name table, as `render --mode` spells them: "preview" (Layered),
// "preview-occlusion", "preview-gather", "preview-scatter".
const char* preview_method_name(PreviewMethod method);
const char* preview_method_label(PreviewMethod method);  // in words, for a menu
// The inverse, also accepting the older names "layered", "layered-occlusion", "gather" and
// "scatter"; nullopt for any other name.
std::optional<PreviewMethod> find_preview_method(const std::string& name);
// find_preview_method, throwing dofcache::Error listing the valid names.
PreviewMethod parse_preview_method(const std::string& name);
const std::vector<std::string>& preview_method_names();

// The composites' names: "over", "slabs" (options.h).
const char* layer_composite_name(LayerComposite composite);
const char* layer_composite_label(LayerComposite composite);  // in words, for a menu
LayerComposite parse_layer_composite(const std::string& name);  // throws dofcache::Error
const std::vector<std::string>& layer_composite_names();

// A_j of the paper: the scene rendered with the near clipping plane at layer j's depth, valid where
// mask = 1 (the mask build_occlusion_masks gave for layer j, or a subset of it).
struct RevealedLayer {
  double near_depth = 0;  // must equal plan.layers[j].depth of the plan render_preview makes
  image::Image color;     // RGB linear
  image::Image depth;     // 1 channel, camera-space z (metres)
  image::Image mask;      // 1 channel, 1 where color/depth are valid
};

struct PreviewInputs {
  image::Image color;  // RGB linear, the pinhole render
  image::Image depth;  // 1 channel, camera-space z in metres, +inf for background / miss
  image::Image ids;    // 1 channel, float-encoded object or primitive id, -1 for none (L_0)
  lens::LensImaging imaging;
  std::vector<RevealedLayer> revealed;  // LayeredOcclusion only; any order, any subset of layers
};

// Wall-clock milliseconds per stage of one render_preview call.
struct PreviewTimings {
  double setup_ms = 0;       // CoC map, layer plan, revealed-layer index
  double fill_ms = 0;        // layered: culling + revealed fill + pull-push disocclusion
  double matting_ms = 0;     // layered: mattes, premultiplication, layer bounding boxes
  double blur_blend_ms = 0;  // layered: pyramid blur; "over" is fused into its last expand
  double filter_ms = 0;      // gather / scatter: the whole filter
  double resolve_ms = 0;     // division by total alpha, output image
  double trace_ms = 0;       // occlusion fix: lens rays traced in the edge band
  double total_ms = 0;
  int layers = 0;          // layers planned (layered methods)
  int layers_blurred = 0;  // layers whose matte was not empty
  long traced_pixels = 0;  // occlusion fix: pixels of the edge band whose lens rays were traced
  bool shaped_bokeh = false;  // the lens is not plain: drawn by the shaped scatter (see above)
  int revealed_layers = 0;      // shaped scatter with the occlusion fix: revealed layers used
  long revealed_fragments = 0;  // and the surfaces in them it splatted
};

// Reusable scratch memory: keep one across frames to avoid reallocating buffers.
class PreviewWorkspace {
 public:
  PreviewWorkspace();
  ~PreviewWorkspace();
  PreviewWorkspace(const PreviewWorkspace&) = delete;
  PreviewWorkspace& operator=(const PreviewWorkspace&) = delete;
  struct Impl;
  Impl& impl() { return *impl_; }

 private:
  std::unique_ptr<Impl> impl_;
};

// The lens's own bokeh. With a lens that is not plain (lens/aperture.h: blades, an anamorphic
// squeeze, an aperture image, a vignetting stop, a real lens's rims, chromatic aberration, tilt
// or shift), every
// method draws it with the shaped scatter: each pixel splats the aperture's shape where the lens
// puts its rays (render::ThinLensCamera::bokeh: turned by 180 degrees in front of the plane of
// focus, scaled by the band's and the tilted plane's circle of confusion, its centre moved by
// lateral chromatic aberration, cut by the stop's disc and dimmed by the light the stop takes,
// or cut by a real lens's rims and, where its image is normalised for them, as bright as uncut),
// binned and composited far to near as the disk scatter (baselines.h), with each colour channel's
// own coverage. The layered methods' pyramid blurs round discs of one radius per depth, which a
// tilted plane, a cat's eye or colour fringes break; PreviewTimings::shaped_bokeh says when this
// path ran. A graded transmission (a profile, an aperture image's grey levels) is drawn as levels
// (aperture_rows.h). With LayeredOcclusion, the surfaces its revealed layers hold (what the lens
// sees past a blurred foreground's rim, hidden in the pinhole image) are splatted too, each into
// its depth's bin, so they show where the splats in front leave coverage: the fix and the shape
// together.
//
// What a front end says when the shaped scatter draws a preview (one line).
inline constexpr const char* kShapedPreviewNotice =
    "the preview draws this lens's bokeh with its shaped scatter (the aperture's shape, the "
    "vignetting stop or the lens's rims, the transmission, the colour bands and the tilted "
    "plane, pixel by pixel), with the occlusion fix's revealed surfaces where the method has it; "
    "the layered methods' pyramid is left out";

// What a front end says when the preview draws a real lens (lens/real_lens.h): as its thick-lens
// equivalent, whose circle of confusion the traced bokeh follows (tests/render/
// real_lens_render_test.cpp), cut to the cat's eyes of its rims (lens/lens_rims.h), through the
// pinhole projection from its front principal plane.
inline constexpr const char* kRealLensPreviewNotice =
    "the preview draws the real lens as its thick-lens equivalent (the bokeh of its circle of "
    "confusion in its stop's shape, cut to the cat's eyes of its rims; a perspective "
    "projection); the distortion and aberrations of its traced render are left out";
// Beyond this corner distortion (lens::MountedLens::corner_distortion) a real lens is not drawn
// by the preview's perspective projection (a fisheye): resolve() refuses it in one line.
inline constexpr double kMaxPreviewDistortion = 0.1;

// The preview (RGB). If every |CoC| is at most 1 px (zero aperture, or everything at the focus
// distance) every method returns the input colour unchanged. LayeredOcclusion without revealed
// layers is Layered. Throws dofcache::Error on mismatched image shapes, or a revealed layer whose
// near_depth matches no layer of the plan.
image::Image render_preview(const PreviewInputs& inputs, PreviewMethod method,
                            const PreviewOptions& options, PreviewTimings* timings = nullptr);
image::Image render_preview(const PreviewInputs& inputs, PreviewMethod method,
                            const PreviewOptions& options, PreviewWorkspace& workspace,
                            PreviewTimings* timings = nullptr);

}  // namespace dofcache::preview
