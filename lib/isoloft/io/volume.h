// @file io/volume.h
// @brief A dense 3D scalar volume (label maps, distance fields) in DICOM
// patient space, and reading and writing it by file name.
//
// Sample (i, j, k) sits at origin + direction * (i sx, j sy, k sz): patient
// coordinates in mm, LPS (x to the patient's left, y posterior, z superior;
// NIfTI's RAS is converted on reading). Formats: NIfTI (.nii, .nii.gz,
// niftilib), NRRD (.nrrd, .nhdr, teem), MetaImage (.mha, .mhd, our own).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "isoloft/core/grid.h"
#include "isoloft/core/mesh.h"

namespace isoloft {

struct Volume {
  int nx = 0, ny = 0, nz = 0;
  std::array<double, 3> spacing{1.0, 1.0, 1.0};  ///< voxel size along voxel axes i, j, k (mm)
  std::array<double, 3> origin{0.0, 0.0, 0.0};   ///< patient position of voxel (0, 0, 0)'s centre
  /// Column a: the patient (LPS) unit direction of voxel axis a.
  Eigen::Matrix3d direction = Eigen::Matrix3d::Identity();
  bool integer = false;                          ///< the file holds integers (a label map), not floats
  std::vector<float> data;                       ///< x fastest, then y, then z; size nx*ny*nz
  /// Integer volumes with values a float cannot hold exactly (beyond 2^24 in
  /// magnitude, e.g. int32 labels 16777216 and 16777217): 0, then the other
  /// distinct values ascending, and `data` holds each voxel's index into this
  /// table (0 stays 0; labels stay exact). Empty otherwise: `data` holds the values.
  std::vector<std::int64_t> value_table;
  std::vector<std::string> warnings;             ///< what the reader assumed (e.g. an unknown orientation)

  /// Patient position of the (fractional) voxel index ijk.
  [[nodiscard]] Vec3d to_patient(const Vec3d& ijk) const {
    return Eigen::Map<const Eigen::Vector3d>(origin.data()) +
           direction * Eigen::Map<const Eigen::Vector3d>(spacing.data()).cwiseProduct(ijk);
  }

  [[nodiscard]] std::size_t index(int x, int y, int z) const {
    return (std::size_t(z) * std::size_t(ny) + std::size_t(y)) * std::size_t(nx) + std::size_t(x);
  }
  [[nodiscard]] float at(int x, int y, int z) const { return data[index(x, y, z)]; }
  /// The value of sample i (data[i], or its value_table entry).
  [[nodiscard]] double value(std::size_t i) const {
    return value_table.empty() ? double(data[i]) : double(value_table[std::size_t(data[i])]);
  }
  [[nodiscard]] Grid2f plane(int z) const;
};

namespace detail {
/// Element types of the files.
enum class ScalarType { U8, I8, U16, I16, U32, I32, F32, F64 };
}  // namespace detail

/// One plane of samples (nx x ny, 1 or 2 bytes each, as stored) held as runs
/// of equal samples row by row: a label plane costs its runs, not its pixels.
/// @warning A default-made plane (every sample 0, empty()) has no width: its
/// row() and row_floats() write nothing; the caller fills the row.
class SamplePlane {
 public:
  SamplePlane() = default;
  /// Encodes nx * ny samples of `sample_bytes` (1 or 2) bytes each, x fastest.
  /// \throw ParamError for another sample size.
  SamplePlane(const unsigned char* samples, int nx, int ny, std::size_t sample_bytes);
  /// Every sample 0.
  [[nodiscard]] bool empty() const { return runs_ == 0; }
  /// Row j holds only 0 samples.
  [[nodiscard]] bool row_zero(int j) const;
  /// Row j's samples as stored into `out` (nx samples).
  void row(int j, unsigned char* out) const;
  /// Row j as floats (`decode`: the file's type and byte order) into `out`.
  void row_floats(int j, detail::ScalarType type, bool big_endian, float* out) const;
  /// Sample (i, j) as a float.
  [[nodiscard]] float at(int i, int j, detail::ScalarType type, bool big_endian) const;
  /// Bytes held.
  [[nodiscard]] std::size_t bytes() const;

 private:
  int nx_ = 0, ny_ = 0;
  std::size_t size_ = 1;
  std::size_t runs_ = 0;                 // 0: every sample 0 (nothing stored)
  std::vector<std::uint32_t> row_first_;  // per row its first run, then the run count (ny + 1)
  std::vector<std::uint32_t> run_end_;    // per run: the x one past its last sample
  std::vector<std::uint16_t> value_;      // per run: its sample's bytes as stored
};

/// A volume's samples as its file stores them (the reader's buffer: valid
/// during the call that is given them), x fastest, then y, then z.
struct VolumeSamples {
  const unsigned char* bytes = nullptr;  ///< every sample in one buffer; null when `planes` holds them
  detail::ScalarType type = detail::ScalarType::U8;
  bool big_endian = false;
  /// Else plane by plane along k (1- or 2-byte samples as runs), shared, so a
  /// taker may keep them past the call (a reader streams a large sparse
  /// volume this way: memory follows its planes' runs).
  std::shared_ptr<const std::vector<SamplePlane>> planes;
};

/// What a volume file holds, from its header alone.
struct VolumeHeader {
  int nx = 0, ny = 0, nz = 0;
  std::size_t sample_bytes = 0;  ///< bytes of one sample in the file
  /// The files holding the samples besides the header, resolved: a .mhd's
  /// ElementDataFile, a detached .nhdr's data files, a NIfTI .hdr's .img.
  /// A run reads them as it reads the header, so no output may replace them.
  std::vector<std::string> data_files = {};
};

/// How to read a volume.
struct VolumeReadOptions {
  /// Data files a header names (NRRD `data file`, MetaImage `ElementDataFile`)
  /// may lie outside the header's folder (else an error names them).
  bool allow_external_data = false;
  /// Called once the header is read and checked, before any voxel is
  /// allocated or decoded (a budget check throws from here).
  std::function<void(const VolumeHeader&)> on_header;
  /// Offered the samples as stored once they are read and checked, with the
  /// volume's geometry (`data` empty): returning true takes them, and
  /// read_volume decodes nothing and returns the geometry alone (for a reader
  /// that needs a few planes of a large volume). Not offered samples that a
  /// NIfTI scaling (scl_slope, scl_inter) maps to other values.
  std::function<bool(const Volume& geometry, const VolumeSamples& samples)> take_samples;
  /// The header alone (a reference grid): read_volume returns once the
  /// header is read and checked and on_header called, the geometry with
  /// `data` empty; no sample is read, decoded or allocated.
  bool geometry_only = false;
};

/// The extension names a volume format this library reads.
[[nodiscard]] bool is_volume_path(const std::string& path);

/// Reads a volume by extension (.nii .nii.gz .hdr .nrrd .nhdr .mha .mhd).
/// \throw InputError naming the file and the problem (each reader's list),
///        and what options.on_header throws.
Volume read_volume(const std::string& path, const VolumeReadOptions& options = {});

/// Writes a volume by extension (.nii .nii.gz .nrrd .mha), with its geometry;
/// integer volumes as the smallest unsigned/int32 type that holds them;
/// atomically. \throw ParamError for another extension, Error on failure.
void write_volume(const std::string& path, const Volume& v);

namespace detail {

/// Cosine beyond which two unit axes count as not orthogonal (a shear): the
/// per-slice distances are computed in voxel space and need right angles.
inline constexpr double kOrthogonalityTolerance = 1e-4;

/// \throw InputError naming `file` and the first voxel that is NaN or infinite.
void check_finite_voxels(const Volume& v, const std::string& file);

/// The voxel-to-patient geometry every reader and the Python image objects
/// pass: spacing finite and > 0, direction finite with orthogonal unit
/// columns (kOrthogonalityTolerance; a singular or sheared affine is
/// refused), origin finite.
/// \throw InputError naming `file`, the axis and the value.
void check_geometry(const Volume& v, const std::string& file);

/// How a volume's samples are written: uint8, uint16, int32 or uint32 for an
/// integer volume (the smallest that holds its range), else float32.
ScalarType storage_type(const Volume& v);
/// The samples (their values, through value_table) as native-endian bytes of
/// type t (U8, U16, I32, U32 or F32).
std::vector<unsigned char> encode_scalars(const Volume& v, ScalarType t);

std::size_t scalar_size(ScalarType t);

/// count elements of type t (either byte order) to floats, in parallel when
/// they are many. \pre src, dst hold them.
void decode_scalars(const unsigned char* src, std::size_t count, ScalarType t, bool big_endian, float* dst);

/// v.data (sized to v's voxel count) from elements of type t, with
/// v.value_table when 32-bit integers exceed a float's exact range.
/// \throw InputError naming `file` if more than 2^24 distinct values need the table.
void decode_volume(const unsigned char* src, ScalarType t, bool big_endian, Volume& v, const std::string& file);

/// The readers' last step: offers the samples to options.take_samples, and
/// unless taken sizes v.data and decodes them into it (decode_volume).
void take_or_decode(const unsigned char* src, ScalarType t, bool big_endian, Volume& v, const std::string& file,
                    const VolumeReadOptions& options);

/// The readers' last step for raw samples at byte `offset` of regular file
/// `path`: with options.take_samples and 1- or 2-byte samples, the planes
/// along k are read (pread, in parallel, one plane buffer per task) and
/// offered as SamplePlanes (all-0 planes held as nothing; declined, decoded
/// from `mapped` without another offer); else take_or_decode(mapped + offset). `mapped` is the file mapped whole
/// (FileBytes), its size already checked to hold the samples.
/// Reading copies the page cache into a reused buffer; mapping it costs a
/// fault per page range (docs/decisions.md: raw volume planes read, not mapped).
/// 	hrow InputError naming `path` if a read fails or comes short.
void take_or_decode_file(const std::string& path, const unsigned char* mapped, std::uint64_t offset, ScalarType t,
                         bool big_endian, Volume& v, const VolumeReadOptions& options);

}  // namespace detail
}  // namespace isoloft
