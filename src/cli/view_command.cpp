#include <signal.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>

#include "commands.h"
#include "common_options.h"
#include "dofcache/render/setup.h"
#include "dofcache/sequence/camera_path.h"
#include "dofcache/view/browser.h"
#include "dofcache/view/server.h"
#include "dofcache/view/session.h"

namespace dofcache::cli {
namespace {

struct ViewOptions {
  std::string keyframes;
  int port = 0;
  view::ViewSettings settings;
  bool open = false, no_reference = false;
};

int run_view(ViewOptions& o) {
  // SIGINT and SIGTERM are taken by sigwait below; block them before any thread starts so that
  // every thread inherits the mask.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  const request::RenderRequest& q = o.settings.request;
  scene::Scene scene = render::load_scene(q.scene, q.scene_index, q.limits);
  print_warnings(scene.warnings);
  o.settings.reference = !o.no_reference;
  const std::string source = scene.source;
  view::ViewSession session(std::move(scene), q.lens, o.settings);
  // A keyframe file the page would append to must be one already: say so now, not at the click.
  if (!o.keyframes.empty() && std::filesystem::exists(o.keyframes))
    sequence::load_keyframe_path(o.keyframes, session.camera());
  view::ViewServer server(session, view::ServerSettings{o.port, "", o.keyframes, source, sequence::append_keyframe});
  session.start();
  server.start();
  std::printf("scene   %s, %dx%d\n", source.c_str(), session.width(), session.height());
  std::printf("view    %s\n", server.url().c_str());
  std::printf("        (the address holds the access token; Ctrl-C stops the server)\n");
  std::fflush(stdout);
  if (o.open) {
    if (!view::open_in_browser(server.url()))
      std::fprintf(stderr, "dofcache: warning: no browser is known here (set BROWSER); open the "
                           "address above\n");
  }
  int signal_number = 0;
  sigwait(&signals, &signal_number);
  server.stop();
  std::printf("stopped\n");
  std::fflush(stdout);
  // The session holds nothing but memory: rather than wait for the background render in flight
  // (a reference pass can take many seconds), end the process now.
  std::_Exit(0);
}

}  // namespace

Runner add_view_command(CLI::App& app) {
  auto o = std::make_shared<ViewOptions>();
  CLI::App* cmd = app.add_subcommand(
      "view",
      "Look at a scene in the browser: a local web server shows the depth-of-field preview, "
      "refocused where you click, and refines the reference (distributed ray tracing with the "
      "radiance cache) in the background. Listens on 127.0.0.1 only; the printed address holds a "
      "random access token. See docs/view.md.");
  request::RenderRequest& r = o->settings.request;
  add_scene_options(cmd, r);
  add_size_options(cmd, r);
  cmd->add_option("--port", o->port, "TCP port on 127.0.0.1 (0: any free port)")
      ->capture_default_str()
      ->check(CLI::Range(0, 65535));
  cmd->add_flag("--open", o->open, "Also open the address in the browser ($BROWSER or xdg-open)");
  add_lens_options(cmd, r.lens, "the camera's extras.lens");
  add_real_lens_options(cmd, r.lens);  // the page lists the shipped lenses too
  add_seed_and_threads(cmd, r, "Random seed of the inputs and the reference");
  add_shading_options(cmd, r);
  add_environment_options(cmd, r.environment);
  add_adaptive_options(cmd, r);
  add_denoise_option(cmd, r);
  add_cache_options(cmd, r, "The reference's radiance cache: none, octree or vdb (auto: vdb)");
  cmd->add_option("--input-spp", o->settings.input_spp,
                  "Pinhole samples per pixel of the refined preview inputs (the first inputs "
                  "take 1, with cheaper shading)")
      ->capture_default_str()
      ->check(CLI::Range(1, 4096));
  cmd->add_option("--reference-pass-spp", o->settings.reference_pass_spp,
                  "Lens samples per pixel added by each pass of the background reference")
      ->capture_default_str()
      ->check(CLI::Range(1, 4096));
  cmd->add_option("--reference-max-spp", o->settings.reference_max_spp,
                  "The reference stops refining at this many lens samples per pixel")
      ->capture_default_str()
      ->check(CLI::Range(1, 1 << 20));
  cmd->add_option("--keyframes", o->keyframes,
                  "Keyframe file the page's 'Append keyframe' adds the camera and lens to (created "
                  "if missing), for 'dofcache sequence --path'");
  cmd->add_flag("--no-reference", o->no_reference,
                "Do not render the reference in the background (preview only)");
  return [o] { return run_view(*o); };
}

}  // namespace dofcache::cli
