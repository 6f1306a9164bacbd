// Atomic output files: every writer in io/ writes to a hidden sibling temp file
// and renames it onto the final path only when the whole file is written, so a
// failure (exception, full disk, Ctrl-C) never leaves a half-written output
// where a viewer or a later pipeline stage would read it. rename(2) within one
// directory is atomic on POSIX file systems.
#pragma once

#include <string>

namespace isoloft {

/// Create the parent directory of `path` (and its parents) if missing.
/// \throw Error naming the directory when it cannot be created.
void ensure_parent_dir(const std::string& path);

/// A temp file that becomes `final_path` on commit().
///
/// Usage: `AtomicFile f(out); write(f.temp_path()); f.commit();`
/// The destructor removes the temp file unless commit() succeeded.
class AtomicFile {
 public:
  /// Creates the parent directory of `final_path` if needed (ensure_parent_dir).
  /// The temp file is not created here; the writer creates it at temp_path().
  /// \throw Error if the parent directory cannot be created.
  explicit AtomicFile(std::string final_path);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  /// Hidden sibling of the final path that keeps its extension so tools that
  /// sniff the extension still work, e.g. `dir/out.ply` ->
  /// `dir/.out.ply.tmp<pid>-<n>.ply`.
  [[nodiscard]] const std::string& temp_path() const { return temp_; }
  [[nodiscard]] const std::string& final_path() const { return final_; }
  [[nodiscard]] bool committed() const { return committed_; }

  /// Renames the temp file onto the final path (replacing an existing file).
  /// \pre the temp file has been written and closed.
  /// \throw Error if the temp file is missing, already committed, or the rename fails.
  void commit();

 private:
  std::string final_;
  std::string temp_;
  bool committed_ = false;
};

}  // namespace isoloft
