// @file io/atomic_file.h
// @brief Atomic outputs: a hidden temp file renamed onto the path when complete.
// Every writer in io/ uses it (rename is atomic on POSIX), so a failure never
// leaves a partial file (docs/decisions.md: temp file and rename). Every temp
// and staged path is also held in a process-wide registry that a signal
// handler (remove_temp_files_on_signals) unlinks, so SIGINT, SIGTERM and
// SIGHUP leave none either.
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace isoloft {

/// Creates the parent directories of path. \throw Error naming the directory.
void ensure_parent_dir(const std::string& path);

/// `AtomicFile f(out); write(f.temp_path()); f.commit();`: the destructor
/// removes the temp file unless committed.
class AtomicFile {
 public:
  /// Creates the parent directory (ensure_parent_dir); the writer creates the file.
  explicit AtomicFile(std::string final_path);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  /// E.g. `dir/out.ply` -> `dir/.out.ply.tmp<pid>-<n>.ply` (extension kept).
  [[nodiscard]] const std::string& temp_path() const { return temp_; }
  [[nodiscard]] const std::string& final_path() const { return final_; }
  [[nodiscard]] bool committed() const { return committed_; }

  /// Renames the written, closed temp file onto the final path.
  /// \throw Error if it is missing, already committed, or the rename fails.
  void commit();

 private:
  std::string final_;
  std::string temp_;
  int slot_ = -1;  // in the signal registry
  bool committed_ = false;
};

/// Writes text to `path` atomically (temp file + rename).
/// \throw InputError naming the path if it cannot be written.
void write_text_atomic(const std::string& path, const std::string& text);

/// Installs handlers for SIGINT, SIGTERM and SIGHUP that unlink every
/// registered temp and staged file (async-signal-safe: unlink() only), then
/// re-raise the signal with its default action (the exit status shows it).
void remove_temp_files_on_signals();

/// Removes hidden temp and staged siblings of `final_path` left by processes
/// that no longer exist (a run killed by SIGKILL or a power cut); returns how
/// many. Their names carry the writer's pid, so a live run's are kept.
std::size_t remove_stale_temp_files(const std::string& final_path) noexcept;

/// The outputs of one run, appearing together or not at all: each is written
/// (atomically) to a hidden staged sibling, and commit() renames them all into
/// place at the end; destroying the set uncommitted removes the staged files.
/// Staged names keep the extension (a writer may pick its format by it) and
/// start with '.', so a killed run's leftovers are never taken for input.
class OutputSet {
 public:
  OutputSet() = default;
  ~OutputSet();
  OutputSet(const OutputSet&) = delete;
  OutputSet& operator=(const OutputSet&) = delete;

  /// The path to write `final_path` to. \throw Error if its directory cannot be created.
  std::string stage(const std::string& final_path);
  /// Renames every staged file that exists into place; the others (never
  /// written) are ignored. \throw Error naming the file that cannot be moved.
  void commit();
  /// Removes the staged files (also called by the destructor).
  void discard() noexcept;
  /// The staged paths not yet committed (e.g. for a signal handler).
  [[nodiscard]] std::vector<std::string> staged() const;

 private:
  struct File {
    std::string final_path, staged;
    int slot;  // in the signal registry
  };
  std::vector<File> files_;
};

}  // namespace isoloft
