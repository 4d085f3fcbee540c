#pragma once
// What a lens is, as a radiance cache file records it (sequence/cache_file.h): the optical design
// a cache was made through, and every parameter of it in one line.
//
// The design is what is mounted on the camera: the ideal thin lens or a prescription, and the
// stop's shape (blades, rotation, roundness, anamorphic ratio, profile, aperture image), a
// vignetting stop, chromatic aberration, tilt and shift. Focal length, f-number and focus are
// the settings a camera path moves from frame to frame (a rack focus, a zoom, a pull of the
// aperture), so they are described but not part of the design: a cache made at one focus is
// read at another as a path's own frames read it.
#include <cstdint>
#include <string>

#include "dofcache/lens/real_lens.h"
#include "dofcache/lens/thin_lens.h"

namespace dofcache::lens {

struct LensIdentity {
  std::uint64_t design = 0;  // content hash of the design; never 0 for a described lens
  std::string description;   // every parameter, one line (settings too: not compared)
};

// The identity of `lens` (with a real lens: `real`, and `lens` its thin-lens equivalent). An
// aperture image is identified by its bytes, so the same image under another path (a farm node's
// copy) is the same design. Throws dofcache::Error if an aperture image cannot be read.
LensIdentity lens_identity(const ThinLens& lens, const MountedLens& real = {});
// Its two halves: the design's hash, and the description.
std::uint64_t lens_design(const ThinLens& lens, const MountedLens& real = {});
std::string describe_lens(const ThinLens& lens, const MountedLens& real = {});

// The shape of `a` in words ("6 blades, a corner at 20 deg, roundness 0, anamorphic ratio 2");
// "round" for the plain round aperture.
std::string describe_aperture(const ApertureShape& a);

}  // namespace dofcache::lens
