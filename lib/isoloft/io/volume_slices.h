// @file io/volume_slices.h
// @brief A sparsely annotated label volume as a slice stack, and the dense
// label map back from the reconstruction ("fill between slices").
//
// The annotated slices are the slices along one voxel axis (the sparse one,
// or the one asked for) that hold any non-zero voxel; the slices between them
// are what the reconstruction fills. The working grid is the volume's own:
// pixel (x, y) of the slice at index t along axis a is voxel (x, y) of the
// two other axes in order (i, j for a = k; i, k for a = j; j, k for a = i),
// z = t s_a / s (pixels of the in-plane voxel size s). Its patient frame maps
// working pixels to the volume's patient space.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "isoloft/core/grid.h"
#include "isoloft/core/slice_stack.h"
#include "isoloft/io/volume.h"

namespace isoloft {

/// How to slice a volume.
struct VolumeSlicing {
  int axis = -1;                        ///< voxel axis 0, 1, 2 (i, j, k); -1 = the sparse one
  InputKind kind = InputKind::Labels;   ///< Labels (each value an object) or Masks (any non-zero voxel)
};

struct VolumeStack {
  SliceStack stack;            ///< the annotated slices, kind Labels or Masks, with the patient frame
  int axis = 2;                ///< the slicing axis used
  std::vector<int> annotated;  ///< voxel index along `axis` of each slice of the stack
  std::vector<std::string> warnings;
};

/// The annotated slices of `v`.
/// \throw InputError naming `path` for: a NaN or infinite voxel (named);
///        non-integer or negative values with Labels; in-plane voxels that are
///        not square along the axis; fewer than 2 annotated slices.
/// @warning A volume annotated on every slice of every axis is sliced along k.
/// @warning Legal but suspicious annotations become VolumeStack::warnings:
///          a label (or the mask) whose own sparse axis is not the one sliced
///          (along the sliced one it is thin lines: `--axis j` on k-annotated
///          data); an annotated slice inside a label's range that lacks it
///          (a stray voxel of another label made the slice annotated: the
///          label is cut there); a mask slice with under 1 % of the voxels of
///          the annotated slices either side (pinched to a stray voxel). Both
///          only next to a slice that is not annotated: a dense run of
///          slices is data throughout, its gaps real.
VolumeStack volume_stack(const Volume& v, const VolumeSlicing& slicing, const std::string& path);

/// The same, read from a file's samples as stored (VolumeReadOptions::take_samples)
/// a row at a time: no float copy of the volume, and the planes that are all
/// 0 seen on their bytes. `geometry` is the volume without its voxels.
/// \throw ParamError unless slices_samples(samples.type); else as above.
VolumeStack volume_stack(const Volume& geometry, const VolumeSamples& samples, const VolumeSlicing& slicing,
                         const std::string& path);

/// Element types volume_stack reads as stored: the 8- and 16-bit integers
/// (finite, exact as floats, and 0 exactly when their bytes are).
[[nodiscard]] bool slices_samples(detail::ScalarType t);

/// The dense label map on the volume's grid: the annotated slices as they
/// were (Masks: 1 where non-zero), every other voxel the label whose
/// interpolated field is largest there and positive, else 0.
class LabelmapBuilder {
 public:
  /// `input` gives the geometry (its voxels are not read), `annotated` the
  /// annotated slices (VolumeStack::stack, or the job made of it).
  LabelmapBuilder(const Volume& input, const VolumeStack& vs, const SliceStack& annotated);
  /// The working z (pixels) of every voxel slice that is not annotated: the
  /// planes at which to sample the fields (ReconstructOptions::sample_z).
  [[nodiscard]] std::vector<double> sample_z() const;
  /// Object `label`'s field over its crop box at working height z (one of sample_z()).
  void add(std::uint32_t label, const Grid2f& field, const PixelBox& box, double z);
  /// The label volume (integer, the input's geometry).
  [[nodiscard]] Volume finish() const;

 private:
  Volume out_;
  std::vector<float> best_;  // the winning field value per voxel
  int axis_, u_, v_;
  double z_per_index_;
  std::vector<std::uint8_t> annotated_;  // per index along the axis

  [[nodiscard]] float stored_value(std::uint32_t label) const;  // the label, or its value_table index
  [[nodiscard]] std::size_t voxel(int x, int y, int t) const;   // of slice pixel (x, y) at index t
};

namespace detail {
/// The voxel axis along which annotations are sparsest (most empty slices
/// between the first and the last annotated one); k when none is sparse.
int sparse_axis(const Volume& v);
}  // namespace detail

}  // namespace isoloft
