#include "dofcache/core/progress.h"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>

#include "dofcache/core/stopwatch.h"

namespace dofcache {
namespace {

std::string format_duration(double seconds) {
  auto s = static_cast<long>(std::max(0.0, seconds) + 0.5);
  if (s >= 3600) return fmt::format("{}:{:02}:{:02}", s / 3600, (s / 60) % 60, s % 60);
  return fmt::format("{}:{:02}", s / 60, s % 60);
}

}  // namespace

Progress::Progress(std::string label, std::uint64_t total, Display display)
    : label_(std::move(label)),
      total_(std::max<std::uint64_t>(total, 1)),
      enabled_(display == Display::Always || (display == Display::Auto && isatty(STDERR_FILENO))),
      start_(std::chrono::steady_clock::now()) {}

Progress::~Progress() { finish(); }

double Progress::elapsed_seconds() const { return seconds_since(start_); }

std::string Progress::format_line(const std::string& label, std::uint64_t done, std::uint64_t total,
                                  double elapsed, int bar_width) {
  total = std::max<std::uint64_t>(total, 1);
  done = std::min(done, total);
  double fraction = static_cast<double>(done) / static_cast<double>(total);
  int filled = static_cast<int>(fraction * bar_width);
  std::string bar(static_cast<size_t>(filled), '#');
  bar.append(static_cast<size_t>(bar_width - filled), '.');
  std::string eta = done == 0 ? "?" : format_duration(elapsed * (1.0 - fraction) / fraction);
  if (done == total) eta = "0:00";
  return fmt::format("{} [{}] {:3.0f}%  {} elapsed, ETA {}", label, bar, fraction * 100.0,
                     format_duration(elapsed), eta);
}

void Progress::advance(std::uint64_t n) {
  done_.fetch_add(n, std::memory_order_relaxed);
  if (enabled_) draw(false);
}

void Progress::set_label(std::string label) {
  std::lock_guard<std::mutex> lock(mutex_);
  label_ = std::move(label);
}

void Progress::draw(bool force) {
  auto now_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(
                    std::chrono::steady_clock::now() - start_)
                    .count();
  auto last = last_draw_ns_.load(std::memory_order_relaxed);
  if (!force && now_ns - last < 100'000'000) return;
  if (!force && !last_draw_ns_.compare_exchange_strong(last, now_ns)) return;
  std::lock_guard<std::mutex> lock(mutex_);
  std::string line = format_line(label_, done(), total_, elapsed_seconds());
  std::fprintf(stderr, "\r%s\x1b[K", line.c_str());
  std::fflush(stderr);
  drawn_ = true;
}

void Progress::finish() {
  if (finished_) return;
  finished_ = true;
  if (!enabled_) return;
  draw(true);
  std::fputc('\n', stderr);
}

}  // namespace dofcache
