#pragma once
// Temporal filtering of a camera path's written frames: each frame averaged with its neighbours'
// values at the same surface points, reprojected by the centre depth and the cameras, as in
// SVGF's temporal accumulation (Schied et al. 2017) but over a window of frames on both sides
// and after the frames exist, so that a frame's result does not depend on how the path was
// rendered (resume, subsets, farm chunks).
//
// A neighbour's value at the reprojected point counts only where it shows the same thing as the
// pixel does:
//   * the same surface: the same object, its centre depth the reprojected point's depth within a
//     relative tolerance plus the local depth step, and its centre normal agrees (disocclusions
//     are refused, not smeared; nor is a lamp's edge into the ceiling it hangs from);
//   * the same blur: its circle of confusion is the pixel's within half a pixel plus a fraction
//     (a focus pull changes a point's blur from frame to frame);
//   * the same light: its luminance is the pixel's within `sigma_luminance` measured standard
//     deviations of the two frames' raw noise plus a small relative allowance (a highlight that
//     moves across a glossy surface is not dragged along).
// A neighbour's value is interpolated bilinearly among the four pixels around the reprojected
// point (renormalised over those that pass). What passes is averaged with weights inverse to each
// frame's measured noise plus the least among them: frames of similar noise count alike, and an
// estimate far noisier than another frame's (a defocused lamp caught by a few lens samples)
// hardly counts. Background (infinite depth) reprojects by direction.
#include <cstddef>
#include <vector>

#include <glm/mat4x4.hpp>

#include "dofcache/image/image.h"

namespace dofcache::denoise {

struct TemporalFrame {
  const image::Image* color = nullptr;     // RGB, linear: the frame as filtered spatially
  const image::Image* depth = nullptr;     // 1 channel: camera-space depth through the pixel
                                           // centre (+inf: nothing)
  const image::Image* normal = nullptr;    // RGB: the centre ray's normal
  const image::Image* ids = nullptr;       // 1 channel: the centre ray's object id
  const image::Image* coc = nullptr;       // 1 channel: circle of confusion radius, pixels
  // 1 channel: the variance of the raw pixel's luminance (its reflected light's and its emission
  // estimate's: render::LensFeatures).
  const image::Image* variance = nullptr;
  // (x z, y z, z, 1) -> world, for film position (x, y) in pixels at camera-space depth z: the
  // pinhole projection through the lens centre (render::ThinLensCamera::film_to_world).
  glm::mat4 film_to_world{1.0f};
};

struct TemporalFilterOptions {
  float depth_tolerance = 0.02f;  // relative depth mismatch allowed, besides the local depth step
  float normal_cos = 0.9f;        // least cosine between the normals
  float coc_tolerance = 0.25f;    // circle-of-confusion mismatch allowed: 0.5 px + this fraction
  float sigma_luminance = 2.0f;   // luminance steps allowed, in raw standard deviations
  float relative_luminance = 0.05f;  // ... plus this fraction of the pixel's luminance
  int threads = 0;                // core/threads.h
};

// Frame `centre` of `frames` (all of one size, every image given) filtered with the others.
// Throws dofcache::Error on a missing or mis-sized image or `centre` out of range.
image::Image temporal_filter(const std::vector<TemporalFrame>& frames, std::size_t centre,
                             const TemporalFilterOptions& options = {});

}  // namespace dofcache::denoise
