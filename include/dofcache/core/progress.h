#pragma once
// A thread-safe progress bar with ETA for long renders. It draws on stderr only when stderr is a
// terminal (or when forced), at most ten times a second, so logs and CI output stay clean.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <string>

namespace dofcache {

class Progress {
 public:
  enum class Display { Auto, Always, Never };

  Progress(std::string label, std::uint64_t total, Display display = Display::Auto);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  void advance(std::uint64_t n = 1);
  // Changes the label (e.g. "frame 3/24") without resetting the count.
  void set_label(std::string label);
  // Draws the final state and ends the line (only if anything was drawn).
  void finish();

  std::uint64_t done() const { return done_.load(std::memory_order_relaxed); }
  std::uint64_t total() const { return total_; }
  double elapsed_seconds() const;

  // The bar as text, e.g. "render [#####.....]  50%  0:02 elapsed, ETA 0:02". Public for tests.
  static std::string format_line(const std::string& label, std::uint64_t done, std::uint64_t total,
                                 double elapsed_seconds, int bar_width = 30);

 private:
  void draw(bool force);

  std::string label_;
  std::uint64_t total_;
  std::atomic<std::uint64_t> done_{0};
  bool enabled_;
  bool drawn_ = false;
  bool finished_ = false;
  std::chrono::steady_clock::time_point start_;
  std::atomic<std::int64_t> last_draw_ns_{0};
  std::mutex mutex_;
};

}  // namespace dofcache
