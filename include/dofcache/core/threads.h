#pragma once
// The one rule for how many worker threads a request gets. "0 threads" means every core this
// process may use, as TBB counts them: that honours the CPU affinity mask (taskset, a Slurm job's
// cpuset), where std::thread::hardware_concurrency counts every core of the machine. A front end
// that wants to keep a core for itself says so with a policy, not with a different meaning of 0.

namespace dofcache {

enum class CorePolicy {
  AllCores,      // 0 threads: every available core
  LeaveOneCore,  // 0 threads: every available core but one (at least one), e.g. background work
                 // of an interactive front end, which keeps a core to answer the user
};

// Cores this process may use (TBB's default concurrency), at least 1.
int available_cores();

// `requested` threads if > 0, else what `policy` gives from available_cores().
int resolve_threads(int requested, CorePolicy policy = CorePolicy::AllCores);

// Runs `f` in a TBB arena of resolve_threads(threads) threads, so that every parallel loop inside
// uses that many.
template <class F>
void run_with_threads(int threads, const F& f);

}  // namespace dofcache

#include <tbb/task_arena.h>

namespace dofcache {

template <class F>
void run_with_threads(int threads, const F& f) {
  tbb::task_arena arena(resolve_threads(threads));
  arena.execute(f);
}

}  // namespace dofcache
