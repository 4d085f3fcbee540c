#include <cstdio>
#include <exception>
#include <fstream>
#include <map>

#include "commands.h"
#include "dofcache/core/atomic_file.h"
#include "dofcache/core/error.h"
#include "dofcache/image/image_io.h"

namespace dofcache::cli {

void write_json_file(const std::string& path, const nlohmann::json& json) {
  write_atomically(path, [&](const std::string& tmp) {
    std::ofstream out(tmp);
    out << json.dump(2) << '\n';
    out.close();
    if (!out) throw Error("cannot write '" + path + "'");
  });
}

}  // namespace dofcache::cli

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
  try {
    for (auto& [sub, run] : runners) {
      if (!sub->parsed()) continue;
      // Every command but the viewer reads or writes images; the codecs load while it starts.
      // The viewer shows its first preview without them and loads them when asked to save.
      if (sub->get_name() != "view") image::preload_image_codecs();
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
