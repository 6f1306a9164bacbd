// @file core/scratch_file.h
// @brief An unnamed scratch file: bytes moved out of memory while a run
// works and read back later (a streamed combined mesh's parts, a label
// partition's meshes). Made with mkstemp in a given folder and unlinked at
// once, so nothing is left behind whatever ends the process.
// @warning The folder's file system holds the bytes: a tmpfs folder keeps
// them in memory.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>

namespace isoloft {

class ScratchFile {
 public:
  /// `what` names the contents in errors ("the combined mesh's parts").
  /// \throw Error naming `dir` if no file can be made there ("" is ".").
  ScratchFile(const std::string& dir, std::string what);
  ~ScratchFile();
  ScratchFile(const ScratchFile&) = delete;
  ScratchFile& operator=(const ScratchFile&) = delete;

  /// Appends `bytes` at the end. \throw Error naming the folder (disk full).
  void append(const void* data, std::size_t bytes);
  /// Reads `bytes` at `offset`. \throw Error naming the folder.
  void read(std::int64_t offset, void* data, std::size_t bytes) const;
  /// Bytes appended so far.
  [[nodiscard]] std::int64_t size() const { return end_; }

 private:
  std::string dir_, what_;
  std::FILE* fp_ = nullptr;
  std::int64_t end_ = 0;
};

}  // namespace isoloft
