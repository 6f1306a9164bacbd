// NRRD volumes (teem format, http://teem.sourceforge.net/nrrd/format.html),
// readable by 3D Slicer, ParaView and teem's unu. The writer streams one z
// plane at a time so the interpolated distance volume never has to be held
// in memory; the reader is for tests and tools.
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

/// Streaming float32 NRRD writer. Header:
/// `NRRD0004`, `type: float`, `dimension: 3`, `space dimension: 3`,
/// `sizes: nx ny nz`, `space directions: (sx,0,0) (0,sy,0) (0,0,sz)`,
/// `kinds: domain domain domain`, `endian: little`, `encoding: raw|gzip`,
/// `space origin: (ox,oy,oz)` (centre of voxel 0,0,0, physical units).
/// The file appears atomically at finish(); destroying the writer without
/// finish() leaves no file.
class NrrdWriter {
 public:
  /// \pre nx, ny, nz >= 1; spacing finite and > 0; origin finite.
  /// \throw ParamError for bad sizes/spacing; Error naming the path if the file cannot be created.
  NrrdWriter(const std::string& path, int nx, int ny, int nz, std::array<double, 3> spacing,
             std::array<double, 3> origin, NrrdEncoding encoding = NrrdEncoding::Raw);
  ~NrrdWriter();
  NrrdWriter(const NrrdWriter&) = delete;
  NrrdWriter& operator=(const NrrdWriter&) = delete;

  /// Append the next z plane.
  /// \throw ParamError if the plane is not nx by ny or all nz planes were written; Error on I/O failure.
  void write_plane(const Grid2f& plane);
  /// Flush, close and move the file into place.
  /// \throw Error if fewer than nz planes were written or on I/O failure.
  void finish();
  [[nodiscard]] int planes_written() const { return written_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  int nx_, ny_, nz_;
  int written_ = 0;
};

/// Write a whole volume (float32) with NrrdWriter.
/// \throw as NrrdWriter.
void write_nrrd(const std::string& path, const Volume& v, NrrdEncoding encoding = NrrdEncoding::Raw);

/// Read a 3D NRRD (or 2D, as nz = 1): types (u)int8/16/32, float, double;
/// encodings raw and gzip; either endian; data attached or in one detached
/// `data file:`. Spacing from `space directions` (axis-aligned only) or
/// `spacings`; origin from `space origin`.
/// \throw InputError(path, ...) for missing/corrupt files and unsupported features.
Volume read_nrrd(const std::string& path);

}  // namespace isoloft
