#pragma once
// Elapsed wall-clock time on the steady clock: the one timer of every stage, render and benchmark.
#include <chrono>

namespace dofcache {

using SteadyTime = std::chrono::steady_clock::time_point;

inline double seconds_since(SteadyTime start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}
inline double ms_since(SteadyTime start) { return 1e3 * seconds_since(start); }

class Stopwatch {
 public:
  Stopwatch() : start_(std::chrono::steady_clock::now()) {}
  void restart() { start_ = std::chrono::steady_clock::now(); }
  double seconds() const { return seconds_since(start_); }
  double ms() const { return ms_since(start_); }
  SteadyTime start() const { return start_; }

 private:
  SteadyTime start_;
};

}  // namespace dofcache
