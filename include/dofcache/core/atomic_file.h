#pragma once
// Atomic file writing, the one way every writer in the project (images, JSON, Slurm scripts,
// cache files, benchmark results) replaces a file: the content goes to a temporary file in the
// target's directory, which is renamed over the target only once complete. A reader never sees a
// half-written file, and a failed write leaves the target as it was.
#include <string>
#include <string_view>
#include <vector>

namespace dofcache {

// Writes `path` atomically: `write(tmp_path)` produces a complete file at tmp_path
// (temporary_path_for(path)), then it is renamed to `path`. On any exception the temporary file
// is removed and the exception rethrown.
template <class WriteFn>
void write_atomically(const std::string& path, WriteFn&& write);

// What write_bytes_atomically gives the file: Executable adds execute permission for everyone,
// set on the temporary before the rename, so the file never appears without it.
enum class FileMode { Regular, Executable };

// Writes `bytes` to `path` atomically; throws dofcache::Error ("cannot write '<path>'", one line)
// if the temporary file cannot be written or renamed.
void write_bytes_atomically(const std::string& path, std::string_view bytes,
                            FileMode mode = FileMode::Regular);

// "<dir>/.<stem>.tmp-<pid>-<counter><ext>": the target's directory (so the rename is atomic) and
// extension (so writers that choose the format by extension still can), unique in the process.
std::string temporary_path_for(const std::string& path);
// Renames the temporary file over `path`; throws dofcache::Error (one line) if that fails.
void commit_temporary(const std::string& tmp_path, const std::string& path);
void discard_temporary(const std::string& tmp_path) noexcept;

// Removes the temporary files (named as temporary_path_for names them) that a killed run left
// behind for any of `targets`, unless the process that made them still runs. Empty targets are
// skipped; unreadable directories are left alone.
void remove_stale_temporaries(const std::vector<std::string>& targets);

template <class WriteFn>
void write_atomically(const std::string& path, WriteFn&& write) {
  std::string tmp = temporary_path_for(path);
  try {
    write(tmp);
    commit_temporary(tmp, path);
  } catch (...) {
    discard_temporary(tmp);
    throw;
  }
}

}  // namespace dofcache
