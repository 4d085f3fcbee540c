#include "dofcache/sequence/temporal_pass.h"

#include <algorithm>
#include <filesystem>
#include <map>

#include "dofcache/core/error.h"
#include "dofcache/core/stopwatch.h"
#include "dofcache/denoise/render_filter.h"
#include "dofcache/denoise/temporal_filter.h"
#include "dofcache/image/image_io.h"
#include "dofcache/render/renderer.h"

namespace dofcache::sequence {
namespace {

// What the filter needs of one written frame.
struct WrittenFrame {
  image::Image color, depth, normal, ids, coc, variance;
  glm::mat4 film_to_world{1.0f};
};

// The layers request::write_render adds with --denoise on, read back as one block.
const std::vector<std::string> kChannels = {"denoised.R", "denoised.G", "denoised.B", "Z",
                                            "N.X",        "N.Y",        "N.Z",        "id",
                                            "lens.Z",     "variance.Y", "emission_variance.Y"};

image::Image channels_of(const image::Image& all, int first, int count) {
  image::Image out(all.width(), all.height(), count);
  for (std::size_t i = 0; i < all.pixel_count(); ++i)
    for (int c = 0; c < count; ++c)
      out.data()[i * count + c] = all.data()[i * all.channels() + first + c];
  return out;
}

WrittenFrame read_frame(const std::string& path, const FrameSpec& spec,
                        const SequenceSettings& s) {
  image::Image all;
  try {
    all = image::read_channels(path, kChannels);
  } catch (const Error& e) {
    throw Error("temporal filter: frame " + std::to_string(spec.number) + ": " + e.what() +
                " (frames need --denoise on and an EXR --out)");
  }
  if (all.width() != s.render.width || all.height() != s.render.height)
    throw Error("temporal filter: frame " + std::to_string(spec.number) + " (" + path + ") is " +
                std::to_string(all.width()) + "x" + std::to_string(all.height()) +
                ", not the sequence's " + std::to_string(s.render.width) + "x" +
                std::to_string(s.render.height));
  WrittenFrame f;
  f.color = channels_of(all, 0, 3);
  f.depth = channels_of(all, 3, 1);
  f.normal = channels_of(all, 4, 3);
  f.ids = channels_of(all, 7, 1);
  // The pixel's noise: its reflected light's and its emission estimate's (a lamp's edge).
  f.variance = channels_of(all, 9, 1);
  for (std::size_t i = 0; i < f.variance.pixel_count(); ++i)
    f.variance.data()[i] += all.data()[i * all.channels() + 10];
  render::RenderSettings rs = s.render;
  rs.lens = spec.lens;  // the frame's own lens (a path may animate focus and aperture)
  const render::ThinLensCamera camera = render::make_camera(spec.camera, rs);
  f.coc = s.render.mode == render::Mode::Pinhole
              ? image::Image(all.width(), all.height(), 1, 0.0f)
              : denoise::coc_radius_image(f.depth, channels_of(all, 8, 1), camera.imaging());
  f.film_to_world = camera.film_to_world();
  return f;
}

}  // namespace

void run_temporal_pass(const std::vector<FrameSpec>& frames, const SequenceSettings& s,
                       const std::function<void(const TemporalFrameReport&)>& on_frame) {
  if (s.temporal_window <= 0) throw Error("temporal filter: no window (--temporal N)");
  s.validate();
  const int n = static_cast<int>(frames.size()), k = s.temporal_window;
  if (n == 0) return;
  {
    const std::filesystem::path dir =
        std::filesystem::path(frame_path(s.temporal_output, frames[0].number)).parent_path();
    std::error_code ec;
    if (!dir.empty()) std::filesystem::create_directories(dir, ec);
    image::check_output_path(frame_path(s.temporal_output, frames[0].number));
  }
  denoise::TemporalFilterOptions options;
  options.threads = s.render.threads;
  // The frames of the window, each read once as the window slides.
  std::map<int, WrittenFrame> loaded;
  for (int i = 0; i < n; ++i) {
    const Stopwatch clock;
    const int lo = std::max(0, i - k), hi = std::min(n - 1, i + k);
    while (!loaded.empty() && loaded.begin()->first < lo) loaded.erase(loaded.begin());
    for (int j = lo; j <= hi; ++j)
      if (!loaded.count(j))
        loaded.emplace(j, read_frame(frame_path(s.output, frames[j].number), frames[j], s));
    std::vector<denoise::TemporalFrame> window;
    for (int j = lo; j <= hi; ++j) {
      const WrittenFrame& f = loaded.at(j);
      window.push_back(
          {&f.color, &f.depth, &f.normal, &f.ids, &f.coc, &f.variance, f.film_to_world});
    }
    const image::Image filtered =
        denoise::temporal_filter(window, static_cast<std::size_t>(i - lo), options);
    TemporalFrameReport rep;
    rep.frame = frames[i].number;
    rep.index = i;
    rep.count = n;
    rep.neighbours = hi - lo;
    rep.path = frame_path(s.temporal_output, frames[i].number);
    const WrittenFrame& centre = loaded.at(i);
    image::write_image(rep.path, filtered,
                       {{{"Z"}, centre.depth},
                        {{"N.X", "N.Y", "N.Z"}, centre.normal},
                        {{"id"}, centre.ids}});
    rep.seconds = clock.seconds();
    if (on_frame) on_frame(rep);
  }
}

}  // namespace dofcache::sequence
