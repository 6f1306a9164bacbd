// @file io/nrrd.h
// @brief NRRD volumes (teem) for 3D Slicer, ParaView, unu: writer and reader.
// The float32 writer streams one z plane at a time: the volume is never held.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>

#include <Eigen/Core>

#include "isoloft/core/grid.h"
#include "isoloft/io/volume.h"

namespace isoloft {

enum class NrrdEncoding {
  Raw,   ///< "encoding: raw": fastest, largest
  Gzip,  ///< "encoding: gzip" (zlib deflate, gzip wrapper)
};

/// Where the samples lie: sample (i, j, k) at origin + axes * (i, j, k).
struct NrrdGeometry {
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();  ///< columns: the step of each voxel axis
  std::array<double, 3> origin{0.0, 0.0, 0.0};          ///< centre of sample (0, 0, 0)
  bool patient = false;  ///< axes in DICOM patient space ("space: left-posterior-superior"), else unnamed
};

/// NRRD0004 float32 writer, `space origin` = centre of sample (0, 0, 0); the
/// file appears atomically at finish(), else never.
class NrrdWriter {
 public:
  /// Axis-aligned samples, `spacing` apart, in an unnamed 3D space.
  /// \throw ParamError unless sizes >= 1, spacing finite > 0, origin finite;
  ///        Error naming the path if the file cannot be created.
  NrrdWriter(const std::string& path, int nx, int ny, int nz, std::array<double, 3> spacing,
             std::array<double, 3> origin, NrrdEncoding encoding = NrrdEncoding::Raw);
  /// \throw ParamError unless sizes >= 1, the axes finite and independent, the origin finite.
  NrrdWriter(const std::string& path, int nx, int ny, int nz, const NrrdGeometry& geometry,
             NrrdEncoding encoding = NrrdEncoding::Raw);
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

/// Reads a 2D (nz = 1) or 3D scalar NRRD with teem: every encoding and type
/// teem reads (integers up to 32 bit, float, double), attached or detached
/// data (in the header's folder or below unless
/// options.allow_external_data); geometry from `space directions` and
/// `space origin` (LPS, RAS, LAS and unnamed spaces, taken to patient LPS)
/// or from `spacings`. The header is read first (teem, data skipped) and
/// checked before any data is: sizes against what the data files can hold,
/// options.on_header. ZRL data is decoded here, bounded (teem's own ZRL
/// reader counts in 32 bits and pads short data with 255).
/// 32-bit integer labels stay exact (Volume::value_table).
/// \throw InputError naming the file and teem's reason (its innermost
///        message) for a corrupt or truncated file, or for gzip data that
///        fails its checksum (teem reads only the bytes it needs); for a data
///        file outside the header's folder, not a regular file, or stdin
///        ("-"); for 4D data, non-scalar axes, sheared axes. NaN samples are
///        kept as they are.
Volume read_nrrd(const std::string& path, const VolumeReadOptions& options = {});

/// Writes `v` with teem (gzip), its geometry in patient LPS; integer volumes
/// as uint8, uint16, int32 or uint32, else float32; atomically.
/// \throw Error naming the path on failure.
void write_nrrd_volume(const std::string& path, const Volume& v);

}  // namespace isoloft
