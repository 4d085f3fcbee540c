#include "dofcache/preview/refocus.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <string>
#include <utility>
#include <vector>

namespace dofcache::preview {
namespace {


bool same_depth(double a, double b) { return a == b || std::abs(a - b) <= 1e-9 * std::abs(a); }

std::string metres(double z) {
  if (!std::isfinite(z)) return "inf";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", z);
  return buf;
}

// True if every saved layer's near depth is a depth of `plan`: the layers were made for it.
bool made_for(const std::vector<RevealedLayer>& revealed, const LayerPlan& plan) {
  for (const RevealedLayer& r : revealed) {
    bool found = false;
    for (const PreviewLayer& l : plan.layers) found = found || same_depth(l.depth, r.near_depth);
    if (!found) return false;
  }
  return true;
}

// Re-slices the saved fragments for `plan`: layer j (1 <= j < n) gets, per pixel, the nearest
// saved fragment with z_j <= depth < z_{j+1}. Layers that receive nothing are left out. The
// fragments are few (rings around occluders), so they are gathered into a list, and the saved
// layers' buffers, cleared where they were set, are reused for the new layers (allocating and
// clearing whole images is most of the cost otherwise).
std::vector<RevealedLayer> reslice(std::vector<RevealedLayer> saved, const LayerPlan& plan) {
  std::vector<RevealedLayer> out;
  const int n = plan.size();
  if (n < 2 || saved.empty()) return out;
  const int width = saved[0].mask.width(), height = saved[0].mask.height();
  auto slab_of = [&](double d) {  // the layer whose slab holds depth d (0: in front of z_1)
    int j = 0;
    while (j + 1 < n && d >= plan.layers[j + 1].depth) ++j;
    return j;
  };
  struct Fragment {
    std::uint32_t pixel;
    int layer;
    float depth, rgb[3];
  };
  std::vector<Fragment> fragments;
  for (RevealedLayer& r : saved) {
    float* mask = r.mask.data().data();
    float* depth = r.depth.data().data();
    float* color = r.color.data().data();
    for (size_t p = 0, N = r.mask.pixel_count(); p < N; ++p) {
      if (!(mask[p] > 0.5f)) continue;
      const float d = depth[p];
      const int j = std::isfinite(d) ? slab_of(d) : 0;
      if (j > 0)
        fragments.push_back({static_cast<std::uint32_t>(p),
                             j,
                             d,
                             {color[3 * p], color[3 * p + 1], color[3 * p + 2]}});
      mask[p] = 0.0f, depth[p] = std::numeric_limits<float>::infinity();  // clear for reuse
      color[3 * p] = color[3 * p + 1] = color[3 * p + 2] = 0.0f;
    }
  }
  // Nearest first per (layer, pixel), so the first of each run wins.
  std::sort(fragments.begin(), fragments.end(), [](const Fragment& a, const Fragment& b) {
    if (a.layer != b.layer) return a.layer < b.layer;
    if (a.pixel != b.pixel) return a.pixel < b.pixel;
    return a.depth < b.depth;
  });
  for (size_t i = 0; i < fragments.size();) {
    const int j = fragments[i].layer;
    RevealedLayer l;
    if (!saved.empty()) {
      l = std::move(saved.back());
      saved.pop_back();
    } else {
      l.color = image::Image(width, height, 3, 0.0f);
      l.depth = image::Image(width, height, 1, std::numeric_limits<float>::infinity());
      l.mask = image::Image(width, height, 1, 0.0f);
    }
    l.near_depth = plan.layers[j].depth;
    for (; i < fragments.size() && fragments[i].layer == j; ++i) {
      const Fragment& f = fragments[i];
      if (l.mask.data()[f.pixel] > 0.5f) continue;  // a nearer one is there
      l.mask.data()[f.pixel] = 1.0f;
      l.depth.data()[f.pixel] = f.depth;
      std::copy_n(f.rgb, 3, l.color.data().data() + 3 * static_cast<size_t>(f.pixel));
    }
    out.push_back(std::move(l));
  }
  return out;
}

}  // namespace

RevealedCoverage revealed_coverage(const LayerPlan& plan, const lens::LensImaging& imaging) {
  RevealedCoverage c;
  if (plan.size() < 2) return c;
  c.present = true;
  c.near_depth = plan.layers[1].depth;
  c.far_depth = plan.layers.back().depth;
  c.aperture_diameter = imaging.lens.aperture_diameter();
  return c;
}

RefocusedInputs refocus_inputs(PreviewInputs saved, const RevealedCoverage& coverage,
                               const lens::ThinLens& lens, const PreviewOptions& options) {
  lens.validate();
  RefocusedInputs r;
  r.inputs.color = std::move(saved.color);
  r.inputs.depth = std::move(saved.depth);
  r.inputs.ids = std::move(saved.ids);
  r.inputs.imaging = saved.imaging;
  r.inputs.imaging.lens = lens;
  r.plan = plan_layers(r.inputs.depth, r.inputs.imaging, options);
  const int n = r.plan.size();
  if (made_for(saved.revealed, r.plan))
    r.inputs.revealed = std::move(saved.revealed);
  else
    r.inputs.revealed = reslice(std::move(saved.revealed), r.plan);

  // Does the saved data cover what the new layers ask for? Only layers 1..n-1 use revealed
  // surfaces (mask_0 is empty), so a one-layer plan needs nothing.
  if (n < 2) return r;
  // The farthest finite new plane (a plane at infinity reveals nothing, so it needs nothing).
  const double near = r.plan.layers[1].depth;
  double far = near;
  for (int j = 1; j < n; ++j)
    if (std::isfinite(r.plan.layers[j].depth)) far = std::max(far, r.plan.layers[j].depth);
  std::string why;
  if (!coverage.present) {
    why = "the saved inputs hold no revealed layers (rendered without the occlusion fix)";
  } else {
    const double tol = 1e-6;
    std::vector<std::string> reasons;
    if (near < coverage.near_depth * (1.0 - tol) ||
        (std::isfinite(far) && far > coverage.far_depth * (1.0 + tol)))
      reasons.push_back("the new layers span " + metres(near) + ".." + metres(far) +
                        " m but the saved revealed layers cover " + metres(coverage.near_depth) +
                        ".." + metres(coverage.far_depth) + " m");
    if (lens.aperture_diameter() > coverage.aperture_diameter * (1.0 + tol)) {
      char buf[160];
      std::snprintf(buf, sizeof buf,
                    "the new aperture (%.3g mm) is wider than the saved one (%.3g mm)",
                    lens.aperture_diameter() * 1e3, coverage.aperture_diameter * 1e3);
      reasons.push_back(buf);
    }
    for (size_t i = 0; i < reasons.size(); ++i) why += (i ? "; " : "") + reasons[i];
  }
  if (!why.empty())
    r.warning = why +
                ": the occlusion fix is only partially valid (what the saved layers miss is "
                "filled by interpolation)";
  return r;
}

}  // namespace dofcache::preview
