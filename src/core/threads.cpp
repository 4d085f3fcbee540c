#include "dofcache/core/threads.h"

#include <algorithm>

#include <tbb/info.h>

namespace dofcache {

int available_cores() { return std::max(1, static_cast<int>(tbb::info::default_concurrency())); }

int resolve_threads(int requested, CorePolicy policy) {
  if (requested > 0) return requested;
  const int cores = available_cores();
  return policy == CorePolicy::LeaveOneCore ? std::max(1, cores - 1) : cores;
}

}  // namespace dofcache
