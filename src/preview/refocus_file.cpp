#include "dofcache/preview/refocus_file.h"

#include <utility>

#include "dofcache/core/stopwatch.h"
#include "dofcache/preview/inputs_file.h"
#include "dofcache/preview/refocus.h"

namespace dofcache::preview {

RefocusFileResult refocus_file(const RefocusFileRequest& q) {
  RefocusFileResult r;
  Stopwatch watch;
  SavedPreviewInputs saved = load_preview_inputs(q.input, q.max_image_values);
  r.load_ms = watch.ms();

  lens::ThinLens& lens = r.lens;
  lens = saved.inputs.imaging.lens;
  lens.focal_length = q.lens.focal_length.value_or(lens.focal_length);
  lens.fstop = q.lens.fstop.value_or(lens.fstop);
  lens.focus_distance = q.lens.focus_distance.value_or(lens.focus_distance);
  const lens::LensRims rims = lens.aperture.rims;  // a real lens's, not a choice
  lens.aperture = q.lens.aperture.over(lens::ApertureChoices::of(lens.aperture)).shape();
  if (!lens.aperture.vignetting()) lens.aperture.rims = rims;  // a stop asked for replaces them
  lens.validate();
  r.method = q.method.value_or(saved.coverage.present ? PreviewMethod::LayeredOcclusion
                                                      : PreviewMethod::Layered);
  PreviewOptions options = saved.options;
  options.threads = q.threads;
  options.layer_composite = q.composite;
  options.edge_rays = q.edge_rays;

  watch.restart();
  RefocusedInputs in = refocus_inputs(std::move(saved.inputs), saved.coverage, lens, options);
  if (r.method == PreviewMethod::LayeredOcclusion) r.warning = in.warning;
  r.image = render_preview(in.inputs, r.method, options);
  r.postprocess_ms = watch.ms();
  r.layers = in.plan.size();
  return r;
}

}  // namespace dofcache::preview
