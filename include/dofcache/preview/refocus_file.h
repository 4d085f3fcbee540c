#pragma once
// `dofcache refocus`: the post-process rerun on preview inputs saved by `render --mode preview...
// --save-preview-inputs`, for another lens (refocus.h does the re-slicing).
#include <cstdint>
#include <optional>
#include <string>

#include "dofcache/image/image.h"
#include "dofcache/image/image_io.h"
#include "dofcache/preview/options.h"
#include "dofcache/preview/preview.h"
#include "dofcache/render/setup.h"

namespace dofcache::preview {

struct RefocusFileRequest {
  std::string input;                        // the saved inputs (.exr)
  std::uint64_t max_image_values = image::kMaxImageValues;
  render::LensOverrides lens;               // each unset value: the saved lens's
  std::optional<PreviewMethod> method;      // unset: the occlusion fix if the file has revealed
                                            // layers, else Kraus & Strengert's layers
  int threads = 0;                          // post-process threads (core/threads.h)
  LayerComposite composite = LayerComposite::Over;
  int edge_rays = PreviewOptions{}.edge_rays;
};

struct RefocusFileResult {
  image::Image image;  // linear RGB
  lens::ThinLens lens;
  PreviewMethod method = PreviewMethod::Layered;
  int layers = 0;
  // Non-empty when the occlusion fix is asked for and the saved revealed layers do not cover what
  // the new lens needs (refocus.h).
  std::string warning;
  double load_ms = 0, postprocess_ms = 0;
};

// Loads, refocuses and post-processes. Throws dofcache::Error on a bad file.
RefocusFileResult refocus_file(const RefocusFileRequest& request);

}  // namespace dofcache::preview
