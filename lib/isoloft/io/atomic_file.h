// @file io/atomic_file.h
// @brief Atomic outputs: a hidden temp file renamed onto the path when complete.
// Every writer in io/ uses it (rename is atomic on POSIX), so a failure never
// leaves a partial file (docs/decisions.md: temp file and rename).
#pragma once

#include <string>

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
  bool committed_ = false;
};

}  // namespace isoloft
