// @file io/atomic_file.h
// @brief Atomic outputs: a hidden temp file renamed onto the path when complete.
// Every writer in io/ uses it (rename is atomic on POSIX), so a failure never
// leaves a partial file (docs/decisions.md: temp file and rename). Every temp
// and staged path is also held in a process-wide registry that a signal
// handler (remove_temp_files_on_signals) unlinks, so SIGINT, SIGTERM and
// SIGHUP leave none either.
//
// A path that is a character device or a FIFO (/dev/null, a pipe), or any
// file reached through /dev or /proc (/dev/stdout redirected to a file), is written in place: no temp file and no rename, which would replace
// the node itself (as root, /dev/null for every process). Such an output
// appears as it is written, not at the end with the others.
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace isoloft {

/// What an output path names now (symbolic links followed).
enum class OutputNode {
  Missing,    ///< nothing there yet
  Regular,    ///< a regular file: replaced by rename
  Directory,  ///< cannot be a file output
  Stream,     ///< a character device or FIFO, or any file reached through /dev or /proc (/dev/stdout): written in place
  Other,      ///< a block device or socket: refused
};
[[nodiscard]] OutputNode output_node(const std::string& path);

/// "a block device", "a socket", "a directory", ...: what `path` is, for messages.
[[nodiscard]] std::string node_kind(const std::string& path);

/// Writes `size` bytes to `file` (created or truncated; a device or FIFO
/// written as it is); messages name `path`.
/// \throw InputError naming `path` and the errno text ("No space left on
///        device", "Read-only file system") if it cannot be written.
void write_file_bytes(const std::string& file, const std::string& path, const void* data, std::size_t size);

/// Creates the parent directories of path. \throw Error naming the directory.
void ensure_parent_dir(const std::string& path);

/// One file, one key: `path` absolute, with "." and ".." and symbolic links
/// resolved as far as it exists ("out/x.nrrd" and "./out/x.nrrd" meet).
[[nodiscard]] std::string output_key(const std::string& path);

/// `AtomicFile f(out); write(f.temp_path()); f.commit();`: the destructor
/// removes the temp file unless committed.
class AtomicFile {
 public:
  /// Creates the parent directory (ensure_parent_dir); the writer creates the
  /// file. A device or FIFO (OutputNode::Stream) is its own temp path.
  /// \throw Error naming the path if it is a block device or a socket.
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
  bool in_place_ = false;  // a device or FIFO: written directly, never renamed or removed
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
/// place at the end; destroying the set uncommitted removes the staged files
/// and the directories it created (when empty). Staged names keep the
/// extension (a writer may pick its format by it) and start with '.', so a
/// killed run's leftovers are never taken for input.
class OutputSet {
 public:
  OutputSet() = default;
  ~OutputSet();
  OutputSet(const OutputSet&) = delete;
  OutputSet& operator=(const OutputSet&) = delete;

  /// Takes the lock of the run's outputs: a hidden ".<name>.lock" beside
  /// `output` (its directory created), held (flock) until commit() or
  /// discard(), so a second run to the same output fails at once instead of
  /// mixing its files with this one's. On a file system without locks the
  /// run goes on unlocked.
  /// \throw Error naming the output and the other run's pid if one holds it.
  void lock(const std::string& output);
  /// The path to write `final_path` to (itself for a device or FIFO).
  /// \throw Error if its directory cannot be created, if the run already
  ///        writes that file (by this name or another: "out/x", "./out/x"),
  ///        or if it is a block device or a socket.
  std::string stage(const std::string& final_path);
  /// Creates directory `dir` (and its parents) as an output: removed again
  /// by discard() if the run fails and it is still empty.
  /// \throw Error naming the directory if it cannot be created.
  void create_directories(const std::string& dir);
  /// Renames every staged file that exists into place; the others (never
  /// written) are ignored; releases the lock. \throw Error naming the file
  /// that cannot be moved.
  void commit();
  /// Removes the staged files and the directories created for them (when
  /// empty), releases the lock (also called by the destructor).
  void discard() noexcept;
  /// `text` with every staged path replaced by its final path: a writer's
  /// error as the user named the file, never a hidden staged name.
  [[nodiscard]] std::string final_names(std::string text) const;
  /// The staged paths not yet committed (e.g. for a signal handler).
  [[nodiscard]] std::vector<std::string> staged() const;

 private:
  struct File {
    std::string final_path, staged;
    std::string key;  // the final path, absolute with links resolved: one file, one key
    int slot;         // in the signal registry
    bool in_place;    // a device or FIFO: written directly (staged == final_path)
  };
  void unlock() noexcept;
  std::vector<File> files_;
  std::vector<std::string> created_dirs_;  // deepest last
  std::string lock_path_;
  int lock_fd_ = -1;
  int lock_slot_ = -1;
};

}  // namespace isoloft
