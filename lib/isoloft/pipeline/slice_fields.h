// @file pipeline/slice_fields.h
// @brief The per-slice stages of reconstruct() (paper 2.1-2.2, or Levin).
// Pure functions of one slice, run over the slices in parallel. A field covers
// the crop box b: its pixel (i, j) is working pixel (b.x0 + i, b.y0 + j).
// Sign convention: positive inside.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "isoloft/contour/fill.h"
#include "isoloft/contour/normals.h"
#include "isoloft/core/grid.h"
#include "isoloft/core/slice_stack.h"
#include "isoloft/fit/mpu.h"
#include "isoloft/interp/spline.h"

namespace isoloft {
struct ReconstructParams;
}

namespace isoloft::detail {

/// One slice of one object: its contour and inside pixels.
struct SliceMasks {
  Grid2u8 contour;  ///< contour pixels (1)
  Grid2u8 inside;   ///< interior or contour (1)
  bool empty = true;  ///< no inside pixel
  /// Open contours found by the even-odd fill, as warnings.
  std::vector<std::string> warnings;
};

/// Contour and inside of `label` (labels input) in slice s (paper 2.1):
/// polygons rasterised, masks as they are, contour images filled (even-odd).
/// \throw InputError naming the slice file for a non-binary contour or mask
///        image (unless params.binarize) or an open contour the fill rejects.
SliceMasks slice_masks(const SliceStack& stack, const Slice& s, const ReconstructParams& params, std::uint32_t label);

/// Bounding box of all insides and contours plus margin, clipped; empty if none.
PixelBox object_box(const std::vector<SliceMasks>& masks, int width, int height, int margin);

/// The Levin field over b: exact signed EDT to the contour pixels (contours,
/// polylines) or to the mask's edge (masks, labels).
Grid2f levin_field(const SliceMasks& m, const PixelBox& b, InputKind kind);

/// Fewer contour points than this cannot carry a conic fit (6 coefficients).
inline constexpr std::size_t kMinMpuPoints = 6;

/// Distance from a pixel within ReconstructParams::mpu_band of a contour pixel
/// to the nearest contour point is at most mpu_band + this, px: a mask's
/// points lie |mask_edge_offset| <= 2 px from their boundary pixels, polygon
/// samples within 1 px of their rasterised pixels (and 1 px to spare). The
/// MPU domain (MpuParams::domain_distance) is the band grown by it, so every
/// evaluated pixel lies in a fitted cell.
inline constexpr double kBandPointMargin = 3.0;

/// One slice through the paper's stages 2.1-2.2.
struct MarkerSlice {
  Grid2f field;            ///< signed distance (narrow band + extension), before the filter
  bool fallback = false;   ///< too few points for a curve: exact pixel distances instead
  long sign_guarded = 0;   ///< pixels whose MPU sign the sign guard overruled
  MpuResult fit;
  OrientedPoints points;   ///< contour points and normals, crop coordinates
  Grid2f mpu, distance;    ///< kept only when asked (figures): raw MPU f, distance before the filter
  double t_mpu = 0, t_dist = 0;  ///< CPU seconds of the two stages
};

/// marker2006 for one slice over b (paper 2.1-2.2): points and normals, the MPU
/// curve (on a finer raster for polylines if polyline_raster_width > 0), the
/// sign guard (docs/decisions.md: sign guard), narrow band, extension.
/// @warning Fewer than kMinMpuPoints oriented points (e.g. a one-pixel island)
/// give the exact pixel distance field (fallback = true).
MarkerSlice marker_slice(const SliceMasks& m, const Slice& s, const PixelBox& b, const ReconstructParams& params,
                         InputKind kind, int stack_width, bool keep_stages);

/// Gives every empty slice a field: a non-empty neighbour's field lowered by
/// (max + cap_depth) / cap_extent (the lower of two), so the object closes in
/// the gap like an end cap; without one the most negative value of all fields.
void fill_empty_slices(std::vector<Grid2f>& fields, const PixelBox& box, const InterpParams& interp);

}  // namespace isoloft::detail
