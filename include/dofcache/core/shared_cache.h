#pragma once
// Objects that are expensive to build (an aperture image's sampling tables, a real lens's
// exit-pupil table) shared by key while anyone holds them: previews, sequences and the viewer
// construct cameras again and again with the same lens. Thread-safe; an entry nobody holds is
// forgotten on the next insertion.
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

namespace dofcache::core {

template <class T>
class SharedCache {
 public:
  // The object under `key`, or make()'s (built outside the lock: two threads may both build it;
  // the first to finish is kept).
  template <class Make>
  std::shared_ptr<const T> get(const std::string& key, Make make) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (auto held = entries_[key].lock()) return held;
    }
    std::shared_ptr<const T> built = make();
    std::lock_guard<std::mutex> lock(mutex_);
    for (auto it = entries_.begin(); it != entries_.end();)
      it = it->second.expired() ? entries_.erase(it) : std::next(it);
    if (auto held = entries_[key].lock()) return held;
    entries_[key] = built;
    return built;
  }

 private:
  std::mutex mutex_;
  std::map<std::string, std::weak_ptr<const T>> entries_;
};

// A file's version: its path, size and modification time (an edited file gets another key);
// nullopt when the file cannot be examined (the reader then gives its own error).
inline std::optional<std::string> file_version_key(const std::string& path) {
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  if (ec) return std::nullopt;
  const auto time = std::filesystem::last_write_time(path, ec);
  if (ec) return std::nullopt;
  return path + '\n' + std::to_string(size) + '\n' +
         std::to_string(time.time_since_epoch().count());
}

}  // namespace dofcache::core
