#pragma once
// Preview inputs on disk, so that `dofcache refocus` can rerun the post-process without
// rendering: one multi-part EXR (32-bit float, so ids and depths round-trip exactly).
//
//   part "color"       R, G, B   the pinhole render (linear). Its attributes (dofcache:<key>):
//                                format = "dofcache-preview-inputs", version = 1,
//                                focal_length, fstop, focus_distance (metres), yfov (radians),
//                                width, height, the layer-planning options (max_coc_radius,
//                                max_layers, min_layer_step, layer_count, mask_lens_reach) and
//                                the revealed layers' coverage (revealed_present,
//                                revealed_near_depth, revealed_far_depth, revealed_aperture);
//                                for a lens that is not plain, its aperture (lens/aperture.h):
//                                aperture_blades, aperture_rotation, aperture_roundness,
//                                anamorphic_ratio, vignetting_stop_radius and _distance,
//                                axial_ca, lateral_ca, aperture_profile, aperture_profile_strength,
//                                lens_tilt_x and _y, lens_shift_x and _y, aperture_image;
//                                a real lens's rims (lens/lens_rims.h) where it has them:
//                                lens_rims_front_radius and _distance, lens_rims_rear_radius
//                                and _distance, lens_rims_normalised (0 or 1)
//   part "depth"       Z         camera-space depth, +inf for no hit
//   part "ids"         id        triangle (or object) ids, -1 for no hit
//   part "revealed.K"  x, y, R, G, B, Z
//                                revealed layer K as the list of its mask's pixels (x, y) with
//                                their colour and depth, row-major, in rows as wide as the image
//                                (unused entries at the end: x = -1). Attributes: near_depth (its
//                                z_j), pixels (the mask's pixel count). The masks are thin rings
//                                around occluders: a list is a fraction of the dense images' size
//                                and load time.
//
// Numbers are stored as decimal strings that round-trip (%.17g; "inf" for infinity).
#include <cstdint>
#include <string>

#include "dofcache/image/image_io.h"
#include "dofcache/preview/options.h"
#include "dofcache/preview/preview.h"
#include "dofcache/preview/refocus.h"

namespace dofcache::preview {

struct SavedPreviewInputs {
  PreviewInputs inputs;
  RevealedCoverage coverage;
  // The layer-planning options the revealed layers were made with (the other fields default).
  PreviewOptions options;
};

// Writes `path` (.exr) atomically. Throws dofcache::Error (one line) on a bad path or failed write.
void save_preview_inputs(const std::string& path, const PreviewInputs& inputs,
                         const RevealedCoverage& coverage, const PreviewOptions& options = {});

// Throws dofcache::Error (one line, naming the file) if it is missing, unreadable, not a
// preview-inputs file, or holds inconsistent sizes or an absurd lens, or if its images, read or
// expanded (the revealed layers), would hold more than `max_values` floats.
SavedPreviewInputs load_preview_inputs(const std::string& path,
                                       std::uint64_t max_values = image::kMaxImageValues);

}  // namespace dofcache::preview
