// @file io/file_util.h
// @brief Whole-file reads, exact-size inflation and size checks shared by the
// readers (meshes, polylines, volumes).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace isoloft::detail {

/// Whole file (from byte `offset`) into memory.
/// \throw InputError(path, ...) if the file is missing or unreadable.
std::vector<unsigned char> read_file_bytes(const std::string& path, std::uint64_t offset = 0);

/// Inflate a zlib or gzip stream (auto-detected) that must decode to exactly
/// `expected` bytes.
/// \throw InputError(file, ...) on corrupt, truncated or wrongly sized data.
std::vector<unsigned char> inflate_exact(const unsigned char* src, std::size_t n, std::size_t expected,
                                         const std::string& file);

/// nx*ny*nz with overflow and sanity checks (each size >= 1, total < 2^34).
/// \throw InputError(file, ...) if the sizes are unusable.
std::size_t checked_voxel_count(int nx, int ny, int nz, const std::string& file);

}  // namespace isoloft::detail
