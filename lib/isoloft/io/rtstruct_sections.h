// @file io/rtstruct_sections.h
// @brief One ROI of an RT Structure Set as world-space sections, on planes
// of any orientation: the input of the 3D methods (roi_stack() in
// io/rtstruct.h stays the axial path of the column methods).
//
// Each closed planar contour's plane is its points' least-squares plane; the
// contours that lie on one plane (every point within kRtOffPlaneToleranceMm of
// it) share one Section. Poses follow io/plane_fit.h: the normal's largest
// component positive (+z for axial planes, whose u, v are then x, y), origin
// the plane's point nearest the patient origin. Contours keep their points
// (patient mm, LPS, projected onto the plane); keyhole cuts are split into
// their loops as roi_stack() splits them; all loops carry label 1 and no hole
// flag: inside by the even-odd rule, as RT systems write holes and islands.
#pragma once

#include <string>
#include <vector>

#include "isoloft/core/section.h"
#include "isoloft/io/rtstruct.h"

namespace isoloft {

/// A contour's points may leave their least-squares plane by this (mm). Twice
/// the worst such offset that rounding contour coordinates to 0.01 mm (the
/// coarsest decimal strings of planning systems) makes on a tilted plane,
/// sqrt(3) x 0.005 = 0.0087 mm, rounded up to 0.02 mm; it is 1/25 of the
/// finest CT pixel (0.5 mm), so a contour within it is flat at the image's
/// resolution. The real breast set (data/rtstruct, 441 closed contours) stays
/// within 1.6e-12 mm.
inline constexpr double kRtOffPlaneToleranceMm = 0.02;

/// Points whose spread across their best line is at most this (mm, RMS) do
/// not determine a plane (rounding tilts it): the same bound as
/// kRtOffPlaneToleranceMm.
inline constexpr double kRtCollinearToleranceMm = kRtOffPlaneToleranceMm;

/// The ROI's closed planar contours as sections, in the order their planes
/// first appear in the ROI's contour sequence (largest contours claim their
/// planes first, so a small contour whose own fit tilts with rounding joins
/// the plane it lies on); Section::source is
/// "<file name>, ROI '<name>', plane <i>" (1-based).
/// \throw InputError(path, "ROI '<name>' contour <k>: not planar ...") for a
///        contour whose points leave their least-squares plane by more than
///        kRtOffPlaneToleranceMm (k 0-based in the ROI's contour sequence, as
///        roi_stack() counts); InputError naming the ROI if no contour is left.
/// @warning Contours that are not CLOSED_PLANAR or have fewer than 3 points
///          are skipped and counted in a warning; so are contours too narrow
///          to give their own plane (within kRtCollinearToleranceMm RMS of a
///          line) that lie on no plane of the ROI's other contours. On such a
///          plane they join it (the breast set's 0.09 mm specks).
std::vector<Section> roi_sections(const RtRoi& roi, const std::string& path, std::vector<std::string>& warnings);

}  // namespace isoloft
