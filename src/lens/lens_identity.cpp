#include "dofcache/lens/lens_identity.h"

#include <map>
#include <mutex>

#include <fmt/format.h>

#include "dofcache/core/content_hash.h"
#include "dofcache/core/file.h"
#include "dofcache/core/shared_cache.h"

namespace dofcache::lens {
namespace {

constexpr std::uint64_t kLensHashSeed = 0x6c656e7364657369ull;  // "lensdesi"

// An aperture image's bytes, hashed once per version of the file (a sequence asks every frame).
std::uint64_t image_hash(const std::string& path) {
  static std::mutex mutex;
  static std::map<std::string, std::uint64_t> hashes;
  const std::string key = core::file_version_key(path).value_or(path);
  {
    std::lock_guard<std::mutex> lock(mutex);
    if (auto it = hashes.find(key); it != hashes.end()) return it->second;
  }
  const std::string bytes = read_file(path, "aperture image");
  const std::uint64_t h = hash_bytes(bytes.data(), bytes.size(), kLensHashSeed);
  std::lock_guard<std::mutex> lock(mutex);
  hashes[key] = h;
  return h;
}

// The shape's fields, each only where it departs from the plain round aperture, so that adding a
// field later leaves the designs of lenses without it as they were.
void add_shape(ContentHasher& h, const ApertureShape& a) {
  if (a.blades != 0) h.add(std::string("blades")), h.add(a.blades), h.add(a.rotation_deg),
      h.add(a.roundness);
  if (a.anamorphic_ratio != 1.0) h.add(std::string("ratio")), h.add(a.anamorphic_ratio);
  if (a.vignetting()) h.add(std::string("stop")), h.add(a.stop.radius), h.add(a.stop.distance);
  if (a.chromatic()) h.add(std::string("ca")), h.add(a.axial_ca), h.add(a.lateral_ca);
  if (a.weighted())
    h.add(std::string("profile")), h.add(static_cast<int>(a.profile)), h.add(a.profile_strength);
  if (a.tilted()) h.add(std::string("tilt")), h.add(a.tilt_x_deg), h.add(a.tilt_y_deg);
  if (a.shifted()) h.add(std::string("shift")), h.add(a.shift_x), h.add(a.shift_y);
  if (!a.image.empty()) h.add(std::string("image")), h.add(image_hash(a.image));
  // A real lens's rims follow from its prescription, which the design holds already.
}

}  // namespace

std::string describe_aperture(const ApertureShape& a) {
  std::string text;
  if (a.blades > 0)
    text += fmt::format("{} blades, a corner at {:g} deg, roundness {:g}", a.blades,
                        a.rotation_deg, a.roundness);
  else
    text += "round";
  if (a.anamorphic_ratio != 1.0) text += fmt::format(", anamorphic ratio {:g}", a.anamorphic_ratio);
  if (a.vignetting())
    text += fmt::format(", vignetting stop {:g} mm across at {:g} mm", 2000.0 * a.stop.radius,
                        1000.0 * a.stop.distance);
  if (a.rims.any()) text += ", the lens's rims (cat's eyes towards the corners)";
  if (a.chromatic())
    text += fmt::format(", chromatic aberration {:g} mm axial, {:g} % lateral",
                        1000.0 * a.axial_ca, 100.0 * a.lateral_ca);
  if (a.weighted())
    text += fmt::format(", {}-weighted transmission (strength {:g})",
                        aperture_profile_name(a.profile), a.profile_strength);
  if (!a.image.empty()) text += ", image " + a.image;
  if (a.tilted()) text += fmt::format(", tilt {:g}, {:g} deg", a.tilt_x_deg, a.tilt_y_deg);
  if (a.shifted()) text += fmt::format(", shift {:g}, {:g}", a.shift_x, a.shift_y);
  return text;
}

std::uint64_t lens_design(const ThinLens& lens, const MountedLens& real) {
  ContentHasher h(kLensHashSeed);
  if (real) {
    h.add(std::string("prescription"));
    // The stop's diameter is the f-number's, a setting; the rest is the glass.
    for (const LensSurface& s : real.lens->surfaces()) {
      h.add(s.radius), h.add(s.thickness), h.add(s.ior), h.add(s.abbe), h.add(s.stop);
      if (!s.stop) h.add(s.aperture_diameter);
    }
    add_shape(h, real.lens->stop_shape());
  } else {
    h.add(std::string("thin lens"));
    add_shape(h, lens.aperture);
  }
  return h.value() == 0 ? 1 : h.value();  // 0 stands for "not recorded" in cache files
}

std::string describe_lens(const ThinLens& lens, const MountedLens& real) {
  if (!real)
    return fmt::format("thin lens {:.4g} mm, f/{:.3g}, focus {:.4g} m, aperture {}",
                       lens.focal_length * 1000.0, lens.fstop, lens.focus_distance,
                       describe_aperture(lens.aperture));
  const RealLens& r = *real.lens;
  return fmt::format("lens {} ({:.1f} mm), f/{:.3g}, focus {} from the sensor, aperture {}",
                     real.source, r.cardinal().focal_length * 1000.0, r.fstop(),
                     r.focused_at_infinity() ? std::string("at infinity")
                                             : fmt::format("{:.4g} m", r.focus_distance()),
                     describe_aperture(r.stop_shape()));
}

LensIdentity lens_identity(const ThinLens& lens, const MountedLens& real) {
  return {lens_design(lens, real), describe_lens(lens, real)};
}

}  // namespace dofcache::lens
