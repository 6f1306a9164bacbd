// @file methods/columns/slice_methods.h
// @brief The columns family's per-slice fields (paper 2.1-2.3, or Levin):
// one slice of one object to its signed distance field over the crop box.
// The methods' registrations (isoloft.cpp, marker2006.cpp, levin.cpp) name
// these as their MethodSpec::slice_field. Sign convention: positive inside.
#pragma once

#include <cstddef>

#include "isoloft/objects/params.h"
#include "isoloft/objects/slice_fields.h"

namespace isoloft::detail {

/// The Levin field over b: exact signed EDT to the contour pixels (contours,
/// polylines) or to the mask's edge (masks, labels).
Grid2f levin_field(const SliceMasks& m, const PixelBox& b, InputKind kind);

/// Whether the slice path keeps the boundary the input gives, with its sign:
/// masks and labels traced (mask_boundary traced), polygons drawn
/// (polyline_boundary drawn); else the MPU fit.
bool takes_given_boundary(InputKind kind, const ReconstructParams& params);

/// Fewer contour points than this cannot carry a conic fit (6 coefficients).
inline constexpr std::size_t kMinMpuPoints = 6;

/// Distance from a pixel within ReconstructParams::mpu_band of a contour pixel
/// to the nearest contour point is at most mpu_band + this, px: a mask's
/// points lie |mask_edge_offset| <= 2 px from their boundary pixels, polygon
/// samples within 1 px of their rasterised pixels (and 1 px to spare). The
/// MPU domain (MpuParams::domain_distance) is the band grown by it, so every
/// evaluated pixel lies in a fitted cell.
inline constexpr double kBandPointMargin = 3.0;

/// marker2006 for one slice over in.box (paper 2.1-2.2): points and normals,
/// the MPU curve (on a finer raster for polylines if polyline_raster_width > 0),
/// the sign guard (docs/decisions.md: sign guard), narrow band, extension;
/// SliceField::field is the distance before the filter.
/// @warning Fewer than kMinMpuPoints oriented points (e.g. a one-pixel island)
/// give the exact pixel distance field (fallback = true).
SliceField marker_slice(const SliceInput& in, const ReconstructParams& params);

/// A mask or label slice traced to its sub-pixel boundary
/// (contour/mask_curve.h) over in.box, and the exact signed distance to that
/// curve: in the band, to its segments (the narrow band stage with linear
/// vertices and saddles joining the inside), beyond by the extension (paper
/// 2.2). No fit: the traced curve is already the smooth curve the pixels
/// allow. SliceField::mpu keeps the traced function (figures).
SliceField traced_mask_slice(const SliceInput& in, const ReconstructParams& params);

/// A polygon slice taken as drawn: the exact distance to its edges in the band
/// (polygon_narrow_band), extended. No fit. SliceField::mpu keeps the band.
SliceField drawn_polygon_slice(const SliceInput& in, const ReconstructParams& p);

/// The curve-fitting methods' slice field (paper 2.1-2.3): traced_mask_slice()
/// for masks and labels with mask_boundary traced, drawn_polygon_slice() for
/// polylines with polyline_boundary drawn, else marker_slice(); then
/// the distance-dependent filter if enabled.
SliceField curve_slice(const SliceInput& in, const ReconstructParams& params);

}  // namespace isoloft::detail
