// @file io/nrrd.h
// @brief NRRD volumes (teem) for 3D Slicer, ParaView, unu: writer and reader.
// The float32 writer streams one z plane at a time: the volume is never held.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>

#include "isoloft/core/grid.h"
#include "isoloft/io/volume.h"

namespace isoloft {

enum class NrrdEncoding {
  Raw,   ///< "encoding: raw": fastest, largest
  Gzip,  ///< "encoding: gzip" (zlib deflate, gzip wrapper)
};

/// NRRD0004 writer, axis-aligned, `space origin` = centre of voxel (0, 0, 0)
/// (physical units); the file appears atomically at finish(), else never.
class NrrdWriter {
 public:
  /// \throw ParamError unless sizes >= 1, spacing finite > 0, origin finite;
  ///        Error naming the path if the file cannot be created.
  NrrdWriter(const std::string& path, int nx, int ny, int nz, std::array<double, 3> spacing,
             std::array<double, 3> origin, NrrdEncoding encoding = NrrdEncoding::Raw);
  ~NrrdWriter();
  NrrdWriter(const NrrdWriter&) = delete;
  NrrdWriter& operator=(const NrrdWriter&) = delete;

  /// Appends the next plane. \throw ParamError if not nx x ny or all written;
  /// Error on I/O failure.
  void write_plane(const Grid2f& plane);
  /// \throw Error if fewer than nz planes were written or on I/O failure.
  void finish();
  [[nodiscard]] int planes_written() const { return written_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  int nx_, ny_, nz_;
  int written_ = 0;
};

/// A whole volume through NrrdWriter.
void write_nrrd(const std::string& path, const Volume& v, NrrdEncoding encoding = NrrdEncoding::Raw);

/// Reads 2D (nz = 1) or 3D NRRD: integer or float types, raw or gzip, either
/// endian, attached or detached data, axis-aligned spacing.
/// \throw InputError(path, ...) for missing/corrupt files and unsupported features.
Volume read_nrrd(const std::string& path);

}  // namespace isoloft
