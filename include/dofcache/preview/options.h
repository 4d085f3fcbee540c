#pragma once
// Settings shared by every preview method (gather, scatter, layered, layered with the occlusion
// fix). One struct, passed down: the renderer that supplies the near-plane id layers must plan the
// layers with the same options as the post-process (see layers.h).

namespace dofcache::preview {

// How the layered methods composite their blurred layers (docs/preview.md, "Composite").
enum class LayerComposite {
  // Kraus & Strengert 2007: trapezoid mattes, blurred layers composited back to front with "over".
  // Copies of one surface in neighbouring layers cover each other as a union, so defocused
  // silhouettes come out wider and more opaque than the lens makes them.
  Over,
  // The hat matte of each layer split at its anchor; the two halves that share a slab between
  // neighbouring anchors are blurred with their layers' radii and added, and the slabs are
  // composited back to front with "over": a surface's shares add up, exactly as the hat weights
  // interpolate the blur, and only nearer slabs occlude it. Twice the blurs, half the matte area.
  // Less error at silhouettes (2-3x in the edge band of the shipped scenes), but a curved surface
  // that crosses an anchor can show a faint seam, and the occlusion fix gains nothing on it yet
  // (docs/preview.md, "Composite"): not the default.
  Slabs,
};

struct PreviewOptions {
  // Worker threads for the post-process (a TBB arena of this size); 0 uses every TBB thread.
  int threads = 0;

  // Denoise the pinhole colour before the post-process (denoise/atrous.h), guided by the pinhole
  // render's albedo, normal, depth and objects, which are free of noise: the quick look at one
  // sample per pixel is then blurred from a clean image. Applies where the scene is rendered
  // (render_preview_inputs), not to saved inputs.
  bool denoise = false;

  // --- circle of confusion ---------------------------------------------------------------------
  // Blur radii (|CoC| / 2, pixels) are clamped to this, so a surface almost touching the lens does
  // not ask for a blur wider than the image.
  double max_coc_radius = 64.0;

  // --- layer planning (layers.h) -----------------------------------------------------------------
  // 0: the automatic rule of plan_layers; > 0 forces this many layers (still evenly spaced).
  int layer_count = 0;
  // Upper bound of the automatic rule (cost is about linear in the layer count). At most 64.
  int max_layers = 12;
  // Smallest spacing of neighbouring layers in CoC *radius* (pixels). The default is half the
  // radius that pyramid level 1 produces (3 px, see pyramid.h).
  double min_layer_step = 1.5;

  // --- composite -------------------------------------------------------------------------------
  LayerComposite layer_composite = LayerComposite::Over;

  // --- pyramid blur (pyramid.h) ------------------------------------------------------------------
  // true: blend the two pyramid levels whose blur brackets the layer radius (variance matched);
  // false: Kraus & Strengert's rounding up to the next power-of-two level (over-blurs).
  bool blend_pyramid_levels = true;
  // Layers whose blur radius is below this (pixels) are blurred directly with the separable
  // disk-profile kernel (pyramid.h, "Small radii") rather than by blending pyramid levels 0 and 1,
  // whose spike-and-halo kernel leaves small defocused silhouettes nearly sharp and opaque. The
  // default is the radius of pyramid level 1 (3 px), where the blend is worst; up to 6.7 px
  // (level 2) the blend is still a narrow core with a wide skirt, but blurring those layers
  // directly costs a third more post-process time at 640x480. 0 always uses the pyramid; values
  // above 24 px act as 24.
  double direct_blur_radius = 3.0;
  // Blur and composite each layer only inside the box its matte covers (plus the kernel support),
  // and there only over each row's runs that can be non-zero. Gives the same image as processing
  // every row of the whole frame; false is for testing that.
  bool crop_layers = true;

  // --- occlusion fix (occlusion.h) ---------------------------------------------------------------
  // Keep only mask pixels that some lens ray can reach (Lee et al. 2010); see occlusion.h.
  bool mask_lens_reach = true;
  // Lens rays per pixel traced through the pinhole surface and the revealed fragments in the band
  // around occluding edges, where the layer composite cannot represent which part of the lens sees
  // past the edge (docs/preview.md, "Edge trace"). Rounded to a square grid; 0 (or anything below
  // 4, the smallest grid with rim probes) keeps the layer composite everywhere. Only the layered
  // method with revealed layers traces.
  int edge_rays = 16;

  // --- scatter baseline --------------------------------------------------------------------------
  // Width of a depth bin of the scatter baseline in signed CoC diameter (pixels). Splats of one bin
  // add up; bins are composited far to near. At most 128 bins are used.
  double scatter_bin_width = 2.0;
};

}  // namespace dofcache::preview
