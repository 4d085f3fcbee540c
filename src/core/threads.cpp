#include "dofcache/core/threads.h"

#include <sched.h>

#include <algorithm>
#include <thread>

namespace dofcache {

int available_cores() {
  // The CPUs of this process's affinity mask (taskset, a Slurm job's cpuset), as TBB counts its
  // default concurrency; read here without starting TBB, which a run that fails early never needs.
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) == 0) return std::max(1, CPU_COUNT(&set));
  return std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
}

int resolve_threads(int requested, CorePolicy policy) {
  if (requested > 0) return requested;
  const int cores = available_cores();
  return policy == CorePolicy::LeaveOneCore ? std::max(1, cores - 1) : cores;
}

}  // namespace dofcache
