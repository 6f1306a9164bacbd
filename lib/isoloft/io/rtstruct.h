// @file io/rtstruct.h
// @brief DICOM RT Structure Sets (DCMTK dcmrt): the ROIs and their planar
// contours, and one ROI as a polyline slice stack in patient space.
//
// Contour points are DICOM patient coordinates in mm (LPS). A ROI becomes
// one slice per contour plane (planes perpendicular to the patient z axis),
// its contours on that plane combined by the even-odd (XOR) rule, as most RT
// systems write holes and islands. A keyhole contour (a hole joined to its
// outer contour by a zero-width cut, traversed once each way) is split into
// its loops first, so the cut leaves no trace.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "isoloft/core/mesh.h"
#include "isoloft/core/slice_stack.h"

namespace isoloft {

struct RtContour {
  std::string type;           ///< ContourGeometricType: CLOSED_PLANAR, OPEN_PLANAR, POINT, ...
  std::vector<Vec3d> points;  ///< patient mm (LPS)
};

struct RtRoi {
  int number = 0;            ///< ROINumber
  std::string name;          ///< ROIName, trailing blanks removed
  std::optional<Rgb> color;  ///< ROIDisplayColor
  std::vector<RtContour> contours;
  [[nodiscard]] int closed_contours() const;
};

struct RtStructureSet {
  std::vector<RtRoi> rois;  ///< in the order of the StructureSetROISequence
  /// The ROI named `name` (exact, then ignoring case), or nullptr.
  [[nodiscard]] const RtRoi* find(const std::string& name) const;
};

/// The file starts like a DICOM Part 10 file ("DICM" after the 128-byte preamble).
[[nodiscard]] bool is_dicom_file(const std::string& path);

/// Reads the ROIs of an RT Structure Set.
/// \throw InputError naming the file: unreadable, truncated or not DICOM; a
///        DICOM of another SOP class (named); an RT Structure Set that DCMTK
///        cannot read; one without any ROI.
RtStructureSet read_rtstruct(const std::string& path);

/// Working grid of a ROI's stack.
struct RoiGrid {
  double voxel_size = 0.5;  ///< in-plane pixel size, mm (the grid DICOM does not give)
  int margin = 34;          ///< pixels around the contours' bounding box (room for the crop margin)
};

/// One ROI as a slice stack of kind Polylines: one slice per contour plane at
/// its own z (non-uniform spacing kept); where planes are missing inside the
/// ROI's z range (a gap of more than 1.5 typical spacings), empty slices at
/// the typical spacing, so each side closes like an end cap instead of being
/// bridged. The stack's patient frame maps working pixels back to mm.
/// \throw InputError naming `path` and the ROI for: no closed planar contour;
///        a contour that is not planar, or whose plane is oblique (not
///        perpendicular to the patient z axis); fewer than 2 contour planes.
/// @warning OPEN_PLANAR and POINT contours are skipped with a warning.
/// @warning Loops smaller than one pixel (area < voxel_size^2) are dropped
///          with a warning: the grid cannot represent them.
SliceStack roi_stack(const RtRoi& roi, const RoiGrid& grid, const std::string& path, std::vector<std::string>& warnings);

namespace detail {

/// Splits keyhole cuts: a closed polygon that runs along an edge and later
/// back along the same edge (within `tol`) becomes two loops, the cut
/// dropped, until none is left. Loops of fewer than 3 points are dropped.
std::vector<std::vector<Vec2d>> split_keyholes(const std::vector<Vec2d>& polygon, double tol);

}  // namespace detail
}  // namespace isoloft
