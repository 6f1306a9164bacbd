// @file io/volume_sections.h
// @brief A label volume annotated on a few slices along any of its three
// voxel axes (3D Slicer's "Fill between slices", ITK's
// MorphologicalContourInterpolator with axis = -1) as world-space sections
// carrying label images.
//
// Which slices are annotated is said, not guessed: a list per voxel axis
// ("k:10,20;i:50") or a mask volume on the same grid whose non-zero voxels
// are the annotated ones (every voxel of an annotated slice marked, so that
// label 0 there means drawn outside, not unknown).
//
// Slice s along voxel axis a is the plane of voxels with index s on a; its
// pixel (x, y) is the voxel whose index on axis (a+1) mod 3 is x and on
// (a+2) mod 3 is y. Pose: origin the patient position of the slice's voxel
// with those indices 0, u and v the patient directions of axes (a+1) mod 3
// and (a+2) mod 3 (so the normal is axis a's direction for a right-handed
// volume), pixel_size their spacing.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "isoloft/core/section.h"
#include "isoloft/io/volume.h"

namespace isoloft {

/// Annotated slice indices per voxel axis (0 = i, 1 = j, 2 = k), ascending, distinct.
struct AnnotatedSlices {
  std::array<std::vector<int>, 3> index;
  [[nodiscard]] std::size_t count() const { return index[0].size() + index[1].size() + index[2].size(); }
};

/// Parses "AXIS:N,N,...;AXIS:N,..." with AXIS one of i, j, k (voxel axes;
/// each at most once), N slice indices within `v`'s size on that axis
/// (repeats allowed, kept once); spaces ignored.
/// \throw ParamError quoting `spec` for a bad axis, a bad or out-of-range
///        index, an axis given twice, or no slice at all.
AnnotatedSlices parse_annotated_slices(const std::string& spec, const Volume& v);

/// The slices of `labels`' grid that `mask` marks whole (every voxel non-zero).
/// \throw InputError naming `mask_path` if its grid differs from `labels`'
///        (sizes, spacing, origin or direction beyond 1e-6 relative), if a
///        marked voxel lies on no whole marked slice (the first named: a
///        slice marked in part says neither drawn nor not drawn), or if it
///        marks no slice.
AnnotatedSlices annotated_slices_from_mask(const Volume& mask, const Volume& labels, const std::string& mask_path);

/// One Section per annotated slice (axis i first, then j, then k, each
/// ascending), its label image the slice's voxel values; Section::source
/// "<file name>, slice <axis>=<index>".
/// \throw InputError naming `path` for a value that is not a label (negative,
///        fractional or beyond 32 bits; the voxel named), a slice whose two
///        in-plane spacings differ (Section has one pixel size), voxel axes
///        that are not orthogonal (beyond detail::kOrthogonalityTolerance),
///        or no slice.
std::vector<Section> label_volume_sections(const Volume& labels, const AnnotatedSlices& slices, const std::string& path);

}  // namespace isoloft
