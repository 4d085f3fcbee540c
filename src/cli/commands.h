#pragma once
// The command-line tool: each subcommand registers its options and a runner. All work happens in
// the library; these files parse, call and print.
#include <functional>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

namespace dofcache::cli {

using Runner = std::function<int()>;

Runner add_render_command(CLI::App& app);
Runner add_compare_command(CLI::App& app);
Runner add_sequence_command(CLI::App& app);
Runner add_refocus_command(CLI::App& app);
Runner add_farm_command(CLI::App& app);
Runner add_view_command(CLI::App& app);

}  // namespace dofcache::cli
