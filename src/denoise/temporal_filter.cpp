#include "dofcache/denoise/temporal_filter.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>
#include <glm/vec4.hpp>

#include "dofcache/core/error.h"
#include "dofcache/core/threads.h"
#include "filter_math.h"

namespace dofcache::denoise {
namespace {

using namespace detail;

void check_frame(const TemporalFrame& f, const image::Image& like) {
  if (!f.color || f.color->empty() || f.color->channels() != 3 ||
      f.color->width() != like.width() || f.color->height() != like.height())
    throw Error("temporal filter: every frame's colour must be RGB of one size");
  check_guide(f.depth, like, 1, "depth");
  check_guide(f.normal, like, 3, "normal");
  check_guide(f.ids, like, 1, "id");
  check_guide(f.coc, like, 1, "circle of confusion");
  check_guide(f.variance, like, 1, "variance");
}

// How much the centre depth may change from a pixel to the next along its surface: per axis the
// smaller step to a neighbour that sees something (an occlusion edge is a large step on one side
// only), the larger of the two axes. A tilted floor then keeps its frames.
std::vector<float> depth_steps(const image::Image& depth) {
  const int w = depth.width(), h = depth.height();
  std::vector<float> steps(depth.pixel_count(), 0.0f);
  const auto at = [&](int x, int y) { return depth.at(x, y, 0); };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float z = at(x, y);
      if (!std::isfinite(z)) continue;
      float axis[2];
      for (int a = 0; a < 2; ++a) {
        float step = std::numeric_limits<float>::infinity();
        for (int d : {-1, 1}) {
          const int qx = x + (a == 0 ? d : 0), qy = y + (a == 1 ? d : 0);
          if (qx < 0 || qy < 0 || qx >= w || qy >= h || !std::isfinite(at(qx, qy))) continue;
          step = std::min(step, std::abs(at(qx, qy) - z));
        }
        axis[a] = std::isfinite(step) ? step : 0.0f;
      }
      steps[static_cast<std::size_t>(y) * w + x] = std::max(axis[0], axis[1]);
    }
  return steps;
}

// A frame's value at the pixel, its noise, and how well its luminance agrees (0 to 1).
struct Candidate {
  float rgb[3];
  float var, accept;
};

float median(std::vector<float>& v) {
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

}  // namespace

image::Image temporal_filter(const std::vector<TemporalFrame>& frames, std::size_t centre,
                             const TemporalFilterOptions& o) {
  if (centre >= frames.size()) throw Error("temporal filter: the centre frame is not among them");
  const TemporalFrame& t = frames[centre];
  if (!t.color) throw Error("temporal filter: every frame's colour must be given");
  for (const TemporalFrame& f : frames) check_frame(f, *t.color);
  const int w = t.color->width(), h = t.color->height();

  // Per neighbour: the centre frame's (x z, y z, z, 1) to its (u z', v z', z', 1), and its depth
  // steps.
  std::vector<glm::mat4> to_film(frames.size());
  std::vector<std::vector<float>> steps(frames.size());
  for (std::size_t s = 0; s < frames.size(); ++s) {
    if (s == centre) continue;
    to_film[s] = glm::inverse(frames[s].film_to_world) * t.film_to_world;
    steps[s] = depth_steps(*frames[s].depth);
  }

  image::Image out(w, h, 3);
  run_with_threads(o.threads, [&] {
    for_rows(h, [&](int y) {
      std::vector<Candidate> taken;
      std::vector<float> order;
      for (int x = 0; x < w; ++x) {
        const float* c = t.color->pixel(x, y);
        const float z = t.depth->at(x, y, 0);
        const bool surface = std::isfinite(z) && z > 0.0f;
        const glm::vec3 n(t.normal->at(x, y, 0), t.normal->at(x, y, 1), t.normal->at(x, y, 2));
        const float coc = t.coc->at(x, y, 0), var = t.variance->at(x, y, 0);
        const float id = t.ids->at(x, y, 0);
        const float lum = luminance(c);
        // The film position scaled by the depth, or a direction for the background.
        const glm::vec4 film = surface ? glm::vec4((x + 0.5f) * z, (y + 0.5f) * z, z, 1.0f)
                                       : glm::vec4(x + 0.5f, y + 0.5f, 1.0f, 0.0f);
        taken.assign(1, Candidate{{c[0], c[1], c[2]}, var, 1.0f});
        for (std::size_t s = 0; s < frames.size(); ++s) {
          if (s == centre) continue;
          const TemporalFrame& f = frames[s];
          const glm::vec4 p = to_film[s] * film;
          if (!(p.z > 0.0f)) continue;  // behind the neighbour's camera
          const float u = p.x / p.z - 0.5f, v = p.y / p.z - 0.5f;  // in pixel-centre units
          if (!(u > -1.0f && v > -1.0f && u < w && v < h)) continue;
          const int x0 = static_cast<int>(std::floor(u)), y0 = static_cast<int>(std::floor(v));
          const float fx = u - x0, fy = v - y0;
          float rgb[3] = {0, 0, 0}, var_s = 0, taps = 0;
          for (int k = 0; k < 4; ++k) {
            const int qx = x0 + (k & 1), qy = y0 + (k >> 1);
            const float b = ((k & 1) ? fx : 1 - fx) * ((k >> 1) ? fy : 1 - fy);
            if (b <= 0.0f || qx < 0 || qy < 0 || qx >= w || qy >= h) continue;
            const float zq = f.depth->at(qx, qy, 0);
            if (surface) {  // the same surface point: its object, depth and normal
              if (f.ids->at(qx, qy, 0) != id || !std::isfinite(zq) ||
                  std::abs(zq - p.z) >
                      o.depth_tolerance * p.z + steps[s][static_cast<std::size_t>(qy) * w + qx])
                continue;
              const float* nq = f.normal->pixel(qx, qy);
              if (glm::dot(n, glm::vec3(nq[0], nq[1], nq[2])) < o.normal_cos) continue;
            } else if (std::isfinite(zq)) {
              continue;  // the background behind the pixel is covered there
            }
            const float coc_q = f.coc->at(qx, qy, 0);
            if (std::abs(coc_q - coc) > 0.5f + o.coc_tolerance * std::max(coc, coc_q)) continue;
            const float* cq = f.color->pixel(qx, qy);
            for (int ch = 0; ch < 3; ++ch) rgb[ch] += b * cq[ch];
            var_s += b * f.variance->at(qx, qy, 0);
            taps += b;
          }
          if (taps < 0.5f) continue;  // most of the footprint shows something else
          for (float& v3 : rgb) v3 /= taps;
          var_s /= taps;
          // Full weight within the allowed luminance step, none beyond twice it.
          const float lum_s = luminance(rgb);
          const float allowed = o.sigma_luminance * std::sqrt(std::max(0.0f, var + var_s)) +
                                o.relative_luminance * std::max(lum, lum_s) + 1e-6f;
          const float a = std::clamp(2.0f - std::abs(lum_s - lum) / allowed, 0.0f, 1.0f);
          if (a > 0.0f) taken.push_back({{rgb[0], rgb[1], rgb[2]}, var_s, a});
        }
        // Each frame weighted by its inverse noise plus the least noise among them (and a floor:
        // a small fraction of their median luminance): frames of similar noise count alike, and
        // one whose estimate here is much noisier than another's (a defocused lamp caught by a
        // few lens samples) hardly counts, be it the centre or a neighbour.
        float least_var = taken[0].var;
        order.clear();
        for (const Candidate& k : taken) {
          least_var = std::min(least_var, k.var);
          order.push_back(luminance(k.rgb));
        }
        const float floor = o.relative_luminance * median(order);
        const float base = least_var + floor * floor + 1e-12f;
        double sum[3] = {0, 0, 0}, weight = 0;
        for (const Candidate& k : taken) {
          const double wk = k.accept / (k.var + base);
          for (int ch = 0; ch < 3; ++ch) sum[ch] += wk * k.rgb[ch];
          weight += wk;
        }
        float* o3 = out.pixel(x, y);
        for (int ch = 0; ch < 3; ++ch) o3[ch] = static_cast<float>(sum[ch] / weight);
      }
    });
  });
  return out;
}

}  // namespace dofcache::denoise
