#pragma once
// The paper's occlusion fix (section 3.2): which pixels of which layer must be rendered again with
// a near clipping plane, so that the post-process can show surfaces the pinhole image hides.
//
// Inputs. The renderer plans the layers first (plan_layers on the pinhole depth, same options as
// the post-process) and renders, with the pinhole camera, an id image L_j for every layer anchor
// j = 0..n-1 with the near clipping plane at plan.layers[j].depth (surfaces at depth >= z_j stay,
// nearer ones are clipped). L_0 is the pinhole id image itself. Ids are floats holding integer
// object or primitive ids, -1 where no surface is hit. Primitive ids are better: with object ids, a
// surface revealed behind a clipped part of the *same* object is not detected.
//
// Mask rule (mask_0 is always empty). For 1 <= j <= n-1, mask_j(p) = 1 iff
//   (1) L_j(p) >= 0 and L_j(p) != L_0(p)            L_j shows a surface the pinhole image does not;
//   (2) j = n-1 or L_{j+1}(p) != L_j(p)             not shared with L_{j+1}: a surface still seen
//                                                  with the near plane at z_{j+1} is revealed by a
//                                                  farther layer, so it is rendered only once. So
//                                                  the surface of mask_j lies in [z_j, z_{j+1});
//   (3) (options.mask_lens_reach) some lens ray reaches it (after Lee et al. 2010):
//         d_j(p) <= rho_j(p) + 0.5, where
//         * open_j: pixels whose pinhole surface the near plane z_j does not clip (c(p) >= c_j);
//         * d_j(p): Euclidean distance between pixel centres from p to the nearest open_j pixel
//           (pixels outside the frame count as closed; infinite if there is none);
//         * rho_j(p) = (c_hi_j - m_j(p)) / 2 with c_hi_j = c_{j+1} (j < n-1) or c(inf) = k
//           (j = n-1), the largest signed CoC the revealed surface can have by (2), and m_j(p) the
//           smallest signed CoC among the clipped pixels in the square window of half-width
//           ceil(max rho_j) around p (the nearest occluder in the neighbourhood).
//       Why: the lens rays through which a hidden point X (signed CoC c_X) at pixel p is seen form
//       a cone; at the depth of an occluder with signed CoC c_F its cross-section, projected to
//       the image, is the disk of radius (c_X - c_F) / 2 px around p (from eqs. (2.4)-(2.6)).
//       If that disk holds no open pixel, every lens ray from X hits the occluder and nothing
//       reveals X. For c_X = 0 (in focus) this is the occluder's own CoC radius |c_F| / 2. The
//       half pixel accounts for the pixel footprint.
// L_j(p) = render::kInsideId (-2) marks the inside of an object the plane cuts (the back of a
// one-sided surface): no lens ray sees it, and by (1) it is never revealed.
// The renderer then renders A_j (colour and depth, same near plane z_j) where mask_j = 1 and hands
// them to render_preview as RevealedLayer{plan.layers[j].depth, color, depth, mask_j}.
#include <vector>

#include "dofcache/image/image.h"
#include "dofcache/lens/thin_lens.h"
#include "dofcache/preview/layers.h"
#include "dofcache/preview/options.h"

namespace dofcache::preview {

// Rule (3) alone, from the pinhole depth: region_j (1 channel, 0 or 1, the depth's size) holds
// the pixels p with d_j(p) <= rho_j(p) + 1/2; region_0 is empty, and without
// options.mask_lens_reach every pixel of the other layers is set. Near a silhouette the region is
// a ring as wide as the blur can reach behind it; the inside of a large occluder is not in it.
// Since it needs no id layer, a renderer can compute it first and trace L_j only where the masks
// read it: inside region_j (rules 1-3 of layer j) and, for rule (2) of layer j-1, inside
// region_{j-1} where L_{j-1} passes rule (1). Elsewhere L_j may be left at L_0: the masks are the
// same (tested). With count >= 0 only the regions of layers below `count` are computed (the
// others are left empty), for a renderer that knows the farther planes reveal nothing (behind
// every surface).
std::vector<image::Image> lens_reach_regions(const image::Image& depth, const LayerPlan& plan,
                                             const lens::LensImaging& imaging,
                                             const PreviewOptions& options = {}, int count = -1);

// The masks from the id layers and the regions of lens_reach_regions: rules (1) and (2), within
// region_j. Throws dofcache::Error on mismatched counts or sizes.
std::vector<image::Image> build_occlusion_masks(const std::vector<image::Image>& id_layers,
                                                const std::vector<image::Image>& regions);

// id_layers[j] = L_j (1 channel, same size as `depth`, the pinhole depth), j = 0..plan.size()-1.
// Returns plan.size() masks (1 channel, 0 or 1): the above with the regions computed here. Throws
// dofcache::Error on mismatched sizes.
std::vector<image::Image> build_occlusion_masks(const std::vector<image::Image>& id_layers,
                                                const image::Image& depth, const LayerPlan& plan,
                                                const lens::LensImaging& imaging,
                                                const PreviewOptions& options = {});

}  // namespace dofcache::preview
