#include <algorithm>
#include <cctype>
#include <cstdio>
#include <exception>
#include <map>

#include "commands.h"
#include "common_options.h"
#include "dofcache/core/error.h"
#include "dofcache/image/image_io.h"

namespace {

// Whether a command will read an image file or write a multi-part EXR (OpenImageIO's work, ~0.4
// CPU-seconds to load): then the image codecs load while it starts. PNG and EXR outputs are
// encoded without them. compare and refocus read images; render, sequence and farm only when an
// argument other than the output (-o, --out) names an EXR or HDR file (environment map, preview
// inputs). The viewer shows its first preview without them and loads them when asked to save. Any
// other use loads them on demand.
bool needs_image_codecs(const CLI::App& command, int argc, char** argv) {
  const std::string name = command.get_name();
  if (name == "view") return false;
  if (name != "render" && name != "sequence" && name != "farm") return true;
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    if (arg == "-o" || arg == "--out") {
      ++i;  // the output's value
      continue;
    }
    if (arg.rfind("--out=", 0) == 0 || (arg.rfind("-o", 0) == 0 && arg.size() > 2)) continue;
    std::transform(arg.begin(), arg.end(), arg.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    for (const char* ext : {".exr", ".hdr"})
      if (arg.find(ext) != std::string::npos) return true;
  }
  return false;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace dofcache;
  CLI::App app{"dofcache: physically based depth of field by distributed ray tracing through a "
               "thin lens, accelerated by a radiance cache.\nRun 'dofcache render' to render the "
               "built-in Cornell box; 'dofcache COMMAND --help' for each command's options."};
  app.require_subcommand(1);
  // Parse errors get the same single-line shape as every other error.
  app.failure_message([](const CLI::App*, const CLI::Error& e) {
    return std::string("dofcache: error: ") + e.what() + " (see --help)\n";
  });
  app.set_version_flag("--version", "dofcache 0.1.0");
  std::map<CLI::App*, cli::Runner> runners;
  auto add = [&](cli::Runner (*fn)(CLI::App&)) {
    std::size_t before = app.get_subcommands({}).size();
    cli::Runner r = fn(app);
    runners[app.get_subcommands({})[before]] = std::move(r);
  };
  add(cli::add_render_command);
  add(cli::add_compare_command);
  add(cli::add_sequence_command);
  add(cli::add_refocus_command);
  add(cli::add_farm_command);
  add(cli::add_view_command);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    int code = app.exit(e);  // prints help/version, or the one-line error
    return code == 0 ? 0 : 2;
  }
  // Every return below waits for a background codec load to finish first.
  struct CodecLoadJoin {
    ~CodecLoadJoin() { image::finish_loading_image_codecs(); }
  } codec_load_join;
  try {
    for (auto& [sub, run] : runners) {
      if (!sub->parsed()) continue;
      // What follows the command's name, for --request (common_options.h).
      for (int i = 1; i < argc; ++i)
        if (sub->get_name() == argv[i]) {
          cli::set_command_arguments(std::vector<std::string>(argv + i + 1, argv + argc));
          break;
        }
      if (needs_image_codecs(*sub, argc, argv)) image::preload_image_codecs();
      return run();
    }
  } catch (const Error& e) {
    std::fprintf(stderr, "dofcache: error: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dofcache: error: %s\n", e.what());
    return 1;
  }
  return 1;
}
