// @file io/file_util.h
// @brief Whole-file reads, exact-size inflation and size checks shared by the
// readers (meshes, polylines, volumes).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace isoloft::detail {

/// A vector of n default values whose pages the kernel may back with huge
/// pages (fewer page faults on first touch for volumes of 100s of MB).
template <class T>
void resize_large(std::vector<T>& v, std::size_t n);

/// \throw InputError(path, ...) unless `path` is a regular file (symbolic
/// links followed): a directory, FIFO, device or socket is refused before it
/// is opened (opening a FIFO blocks until a writer comes; a device may never
/// end), and so is a missing file or a broken link.
void check_regular_file(const std::string& path);

/// A descriptor of regular file `path`, read-only: opened without blocking,
/// then checked (so a FIFO swapped in after check_regular_file() is refused too).
/// \throw InputError(path, ...) as check_regular_file, or if it cannot be opened.
int open_regular_file(const std::string& path);

/// Whole file (from byte `offset`) into memory.
/// \throw InputError(path, ...) if the file is missing, unreadable or not a
///        regular file.
std::vector<unsigned char> read_file_bytes(const std::string& path, std::uint64_t offset = 0);

/// Checks data file `name` that header file `header` names, found at
/// `resolved` (as the format resolves it: relative names from the header's
/// folder). Unless `allow_external`, it must lie in the header's folder or
/// below once symbolic links are resolved (a header must not reach files the
/// user never named, e.g. "../../etc/passwd"); it must be a regular file.
/// \throw InputError(header, ...) naming the data file, and the option that
///        lifts the folder rule (--allow-external-data) when it lies outside.
void check_data_file(const std::string& header, const std::string& name, const std::string& resolved,
                     bool allow_external);

/// A whole file, read-only: mapped into memory (no copy; the page cache's
/// pages), or read (read_file_bytes) where it cannot be mapped.
/// \throw InputError(path, ...) as read_file_bytes.
class FileBytes {
 public:
  explicit FileBytes(const std::string& path);
  ~FileBytes();
  FileBytes(const FileBytes&) = delete;
  FileBytes& operator=(const FileBytes&) = delete;
  [[nodiscard]] const unsigned char* data() const { return map_ ? static_cast<const unsigned char*>(map_) : copy_.data(); }
  [[nodiscard]] std::size_t size() const { return size_; }

 private:
  void* map_ = nullptr;
  std::size_t size_ = 0;
  std::vector<unsigned char> copy_;
};

/// Inflate a zlib or gzip stream (auto-detected) that must decode to exactly
/// `expected` bytes.
/// \throw InputError(file, ...) on corrupt, truncated or wrongly sized data.
std::vector<unsigned char> inflate_exact(const unsigned char* src, std::size_t n, std::size_t expected,
                                         const std::string& file);

/// nx*ny*nz with overflow and sanity checks (each size >= 1, total < 2^34).
/// \throw InputError(file, ...) if the sizes are unusable.
std::size_t checked_voxel_count(int nx, int ny, int nz, const std::string& file);

void advise_huge_pages(void* p, std::size_t bytes);

template <class T>
void resize_large(std::vector<T>& v, std::size_t n) {
  v.reserve(n);
  advise_huge_pages(v.data(), n * sizeof(T));
  v.resize(n);
}

}  // namespace isoloft::detail
