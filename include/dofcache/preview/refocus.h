#pragma once
// Refocusing saved preview inputs: rerunning only the post-process with another lens.
//
// The pinhole colour, depth and ids do not depend on the lens (the field of view is the camera's),
// but the revealed layers A_j of the occlusion fix do: A_j holds, where mask_j is set, the nearest
// surface behind the near plane z_j of the plan they were rendered for, and the masks were cut to
// what that lens's aperture can reach (occlusion.h, rule 3). A new lens plans new depths z'_j.
// The saved fragments are re-sliced for them: a fragment at depth d goes to the new layer j' with
// z'_j' <= d < z'_{j'+1} (the nearest per pixel and layer), which is what the post-process asks for
// (the nearest revealed surface at depth >= z'_{i-1}) wherever the saved layers captured it.
// They capture hidden surfaces only behind z_1 (the first layer's near plane) and only within the
// saved lens's reach, so a new lens whose layers start in front of z_1, end behind z_{n-1}, or
// whose aperture is wider, gets an occlusion fix that is only partially valid: what was not
// captured is filled by pull-push as in Kraus & Strengert's method.
#include <string>

#include "dofcache/lens/thin_lens.h"
#include "dofcache/preview/layers.h"
#include "dofcache/preview/options.h"
#include "dofcache/preview/preview.h"

namespace dofcache::preview {

// The depths whose hidden surfaces a set of revealed layers can supply.
struct RevealedCoverage {
  bool present = false;          // false: no revealed layers were made (no occlusion fix data)
  double near_depth = 0;         // z_1 of the plan the layers were rendered for (metres)
  double far_depth = 0;          // z_{n-1}; +inf if nothing lies at or behind it
  double aperture_diameter = 0;  // F / n of that lens: the lens reach the masks were cut for
};

// The coverage of the revealed layers rendered for `plan` (present iff the plan has 2+ layers;
// far_depth = z_{n-1}, which the renderer raises to +inf when L_{n-1} is empty).
RevealedCoverage revealed_coverage(const LayerPlan& plan, const lens::LensImaging& imaging);

struct RefocusedInputs {
  PreviewInputs inputs;  // the saved pinhole images, the new lens, re-sliced revealed layers
  LayerPlan plan;        // the new lens's plan (same options as the post-process)
  // Empty if the saved layers cover what the new lens's layers need; otherwise one line saying
  // how they fall short (the occlusion fix is then only partially valid).
  std::string warning;
};

// `saved` with its imaging replaced by `lens` (same field of view and resolution). If the new plan
// has exactly the saved near depths, the revealed layers are passed through unchanged (so
// refocusing with the original lens reproduces the original preview bit for bit); otherwise they
// are re-sliced as above. Pass `saved` with std::move to avoid copying the images. Throws
// dofcache::Error if `lens` is absurd (ThinLens::validate).
RefocusedInputs refocus_inputs(PreviewInputs saved, const RevealedCoverage& coverage,
                               const lens::ThinLens& lens, const PreviewOptions& options);

}  // namespace dofcache::preview
