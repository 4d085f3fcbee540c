#pragma once
// The options of `dofcache sequence`, onto a sequence request. Shared with `dofcache farm plan`,
// which parses the same options into the request it stores for each job.
#include <CLI/CLI.hpp>

#include "dofcache/request/render_request.h"

namespace dofcache::cli {

// Registers every `sequence` option (SCENE included) on `cmd`, writing into `r`.
void add_sequence_options(CLI::App* cmd, request::RenderRequest& r);

}  // namespace dofcache::cli
