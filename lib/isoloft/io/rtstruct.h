// @file io/rtstruct.h
// @brief DICOM RT Structure Sets (DCMTK dcmrt): the ROIs and their planar
// contours, and one ROI as a polyline slice stack in patient space.
//
// Contour points are DICOM patient coordinates in mm (LPS). A ROI becomes
// one slice per contour plane (planes perpendicular to the patient z axis),
// its contours on that plane combined by the even-odd (XOR) rule, as most RT
// systems write holes and islands. A keyhole contour (a hole joined to its
// outer contour by a zero-width cut, traversed once each way) is split into
// its loops first, so the cut leaves no trace. Contours whose z differ by
// less than a fifth of the slice spacing share a plane (decimal-string
// rounding jitter), and a ROI on one plane is a slab of one spacing closed by
// the end caps. ROIs are chosen by name or number; two ROIs with one name or
// one number are an error naming them, never merged or picked silently.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "isoloft/core/mesh.h"
#include "isoloft/core/section.h"
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
  /// Another ROI has the same number: contours referring to it cannot be
  /// told apart, so none is assigned (selecting this ROI is an error).
  bool number_shared = false;
  std::string frame_of_reference;  ///< ReferencedFrameOfReferenceUID ("" if none)
  [[nodiscard]] int closed_contours() const;
};

struct RtStructureSet {
  std::vector<RtRoi> rois;  ///< in the order of the StructureSetROISequence
  std::string frame_of_reference;  ///< ReferencedFrameOfReferenceUID of the first ROI ("" if none)
  /// ROI numbers that ROIContourSequence items refer to but the
  /// StructureSetROISequence does not list, with their contour counts (not read).
  std::map<int, int> unlisted_contours;
  /// The file's bytes as read: write_rtstruct() derives from them, so the
  /// file is read once (a file changed meanwhile never mixes into the output).
  std::vector<unsigned char> bytes;
  /// The ROI named `name` (exact, then ignoring case), or nullptr (the first of duplicates).
  [[nodiscard]] const RtRoi* find(const std::string& name) const;
  /// ROIs by name (exact, then ignoring case) or number, in the order asked.
  /// \throw InputError naming `path`: no such ROI (the ROIs listed); a name
  ///        two ROIs share (their numbers listed: select by number); a
  ///        number two ROIs share (their names listed); a text that is one
  ///        ROI's name and another's number.
  [[nodiscard]] std::vector<const RtRoi*> select(const std::vector<std::string>& wanted, const std::string& path) const;
  /// Every ROI with closed planar contours (for a run without --roi).
  /// \throw InputError naming `path` if two ROIs share a number (their
  ///        contours cannot be told apart) or two of them a name (listed:
  ///        select by number), or if none has closed contours.
  [[nodiscard]] std::vector<const RtRoi*> with_contours(const std::string& path, std::vector<std::string>& warnings) const;
};

/// The spacing of the set's contour planes (mm): the median step between the
/// distinct z of all ROIs' closed contours, steps of kPlaneJitterMm or less
/// (rounding jitter within one plane) not counted; 0 if fewer than 2 planes.
double typical_plane_spacing(const RtStructureSet& set);

/// Steps between contour z of at most this (mm) are never taken as a slice
/// spacing: CT slices are thicker, and decimal-string rounding of contour z
/// (SlicerRT #334: 2.4991 / 2.4992 mm steps) stays far below it.
inline constexpr double kPlaneJitterMm = 0.1;

/// Contours whose z differ by at most this share of the slice spacing share a
/// plane (the grouping tolerance; at least kPlanarToleranceMm).
inline constexpr double kPlaneGroupFraction = 0.2;

/// Points of one contour whose z differ by more than max(this, the grouping
/// tolerance) mm are not on one axial plane.
inline constexpr double kPlanarToleranceMm = 0.01;

/// Keyhole cut ends closer than this (mm) are the same point (a cut is written
/// twice with the same decimal strings).
inline constexpr double kKeyholeTolerance = 1e-3;

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
  /// Slice spacing, mm (typical_plane_spacing() of the set, or a reference
  /// CT's): groups contours into planes and gives a one-plane ROI its slab.
  /// 0 = from the ROI's own planes.
  double plane_spacing = 0;
};

/// One ROI as a slice stack of kind Polylines: one slice per contour plane at
/// its own z (non-uniform spacing kept; contours within the grouping
/// tolerance of a plane share it, at their mean z); where planes are missing
/// inside the ROI's z range (a gap of more than 1.5 typical spacings), empty
/// slices at the typical spacing, so each side closes like an end cap instead
/// of being bridged. A ROI on one plane becomes two slices holding its
/// contours a quarter spacing (grid.plane_spacing) below and above it, which
/// the end caps close as a slab of about one spacing (cap_extent of the half
/// spacing beyond each: half a spacing from the plane). The stack's patient
/// frame maps working pixels back to mm; rt_planes() gives the input planes.
/// \throw InputError naming `path` and the ROI for: no closed planar contour;
///        a contour that is not planar, or whose plane is oblique (not
///        perpendicular to the patient z axis); one plane and no spacing known.
/// @warning Contours joined to a plane they lie off by more than
///          kPlanarToleranceMm are counted in a warning.
/// @warning OPEN_PLANAR and POINT contours are skipped with a warning.
/// @warning Loops smaller than one pixel (area < voxel_size^2) are dropped
///          with a warning: the grid cannot represent them.
SliceStack roi_stack(const RtRoi& roi, const RoiGrid& grid, const std::string& path, std::vector<std::string>& warnings);

/// One ROI written back to the planning system: its identity (as read) and
/// its contours, closed polygons per plane (axial, or any plane given its pose).
struct RtRoiContours {
  const RtRoi* roi = nullptr;  ///< number, name and colour written as they were
  struct Plane {
    double z = 0;                            ///< patient z, mm (axial planes)
    std::vector<std::vector<Vec2d>> loops;   ///< patient x, y mm; holes and islands by the even-odd rule
    /// Set for a plane of any orientation: `loops` are in-plane (s, t) mm
    /// on it, written at pose.to_world(), with no Contour Image Sequence; z unused.
    std::optional<PlanePose> pose{};
  };
  std::vector<Plane> planes;
};

/// Writes an RT Structure Set derived from `source` (an RT Structure Set read
/// by read_rtstruct): its patient, study, equipment, frame of reference and
/// referenced series kept; a new series and SOP instance UID, the label
/// `label`, today's date; the ROIs of `rois` only (number, name, colour,
/// observations kept), each with the given contours (CLOSED_PLANAR; on a
/// plane where `source` had a contour of that ROI, its Contour Image
/// Sequence kept). The Frame of Reference module's attributes a structure
/// set lacks are added (FrameOfReferenceUID from the referenced frame,
/// empty PositionReferenceIndicator, empty OperatorsName). Written to a temp
/// file and renamed.
/// `source_bytes`: the source as read (RtStructureSet::bytes), else it is read from `source`.
/// \throw InputError naming `source` (unreadable) or `path` (not writable, with the errno text).
void write_rtstruct(const std::string& path, const std::string& source, const std::vector<RtRoiContours>& rois,
                    const std::string& label, const std::vector<unsigned char>* source_bytes = nullptr);

/// The identity of a structure set written without a source.
struct RtNewSet {
  std::string study;               ///< StudyInstanceUID, new
  std::string frame_of_reference;  ///< FrameOfReferenceUID, new: every ROI's
};

/// Writes a standalone RT Structure Set, for contours with no source set (a
/// label map has no CT series): a new study, series, SOP instance and frame
/// of reference (FrameOfReferenceUID, the ReferencedFrameOfReferenceSequence's
/// one item and every ROI's); the patient module and the study's other type 2
/// attributes present and empty; each ROI of `rois` with its number, name (as
/// a DICOM LO: detail::dicom_lo), colour, generation algorithm AUTOMATIC and
/// interpreted type ORGAN; its contours as write_rtstruct() writes them
/// (without Contour Image Sequences: there are no images). Specific
/// Character Set ISO_IR 192 when a name is not ASCII. Implicit VR Little
/// Endian, written to a temp file and renamed.
/// \throw InputError naming `path`: not writable (with the errno text), or a
///        value DCMTK refuses (the ROI named); Error naming its folder if
///        that cannot be made.
RtNewSet write_rtstruct_new(const std::string& path, const std::vector<RtRoiContours>& rois, const std::string& label);

/// The input contour planes (patient z, mm) of a stack from roi_stack(): its
/// slices with contours, the two slices of a one-plane ROI as their middle.
std::vector<double> rt_planes(const SliceStack& stack);

namespace detail {

/// A LO (Long String) value holds at most this many characters (PS3.5 table 6.2-1).
inline constexpr std::size_t kLoMaxChars = 64;

/// `text` as a DICOM LO value: backslashes (the value separator) and control
/// characters as '_', cut to kLoMaxChars bytes at a UTF-8 character boundary.
std::string dicom_lo(const std::string& text);

/// A ROIName's bytes (`raw`, embedded NULs kept) as UTF-8, decoded once by the
/// file's Specific Character Set `charset` (0008,0005's value: "" or
/// ISO_IR 6 ASCII, ISO_IR 100 Latin-1, ISO_IR 192 UTF-8, "\\ISO 2022 IR 87"
/// Japanese, ...; DCMTK's converter on iconv); trailing blanks removed.
/// Without a declared set, bytes that are UTF-8 are taken as UTF-8.
/// \throw InputError naming `path` and the ROI number: a NUL in the name;
///        bytes not valid in the set; a set DCMTK cannot convert.
std::string decode_roi_name(const std::string& raw, std::string charset, int number, const std::string& path);

/// Splits keyhole cuts: a closed polygon that runs along an edge and later
/// back along the same edge (within `tol`) becomes two loops, the cut
/// dropped, until none is left. Loops of fewer than 3 points are dropped.
std::vector<std::vector<Vec2d>> split_keyholes(const std::vector<Vec2d>& polygon, double tol);

}  // namespace detail
}  // namespace isoloft
