// @file objects/slice_fields.h
// @brief Per-slice preparation shared by the slice methods (paper 2.1): a
// slice's contour and inside masks, packed between passes, the label scan,
// crop boxes, the fields of empty slices; and what a slice method reads and
// returns (SliceInput, SliceField; the methods: methods/columns/slice_methods.h).
// Pure functions of one slice, run over the slices in parallel. A field covers
// the crop box b: its pixel (i, j) is working pixel (b.x0 + i, b.y0 + j).
// Sign convention: positive inside.
#pragma once

#include <algorithm>
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

/// Slices computed at once per thread: 4 keeps a batch's end (waiting for its
/// slowest slice) short, 2 was ~13 % slower; each one in flight holds its
/// masks and fit (docs/decisions.md: slices streamed).
inline constexpr std::size_t kSlicesPerThread = 4;

/// Slices computed at once (kSlicesPerThread x the threads), and so held by
/// reconstruct() as slice fields before the spline's knots.
std::size_t slice_window();

/// Slice fields held at most before the spline's knots: the batch handed
/// out, and the next computing while it is meshed (2 x slice_window()).
std::size_t slices_in_flight();

/// Slices computed at once per label of a label partition of `labels`:
/// slice_window() shared among them, at least 1. Its labels' streams are
/// pulled side by side, so each needs no window of its own (docs/decisions.md,
/// large label stacks). The fields are the same.
std::size_t partition_slice_window(std::size_t labels);

/// The part of g inside b (b within g).
template <class T>
Grid2<T> crop(const Grid2<T>& g, const PixelBox& b) {
  Grid2<T> out(b.width(), b.height());
  for (int y = b.y0; y < b.y1; ++y) std::copy_n(&g(b.x0, y), b.width(), &out(0, y - b.y0));
  return out;
}

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

/// A slice's masks kept between reconstruct()'s two passes: each mask as its
/// runs of 1s, [begin, end) in row-major pixel index, so O(contour length)
/// bytes instead of two full images (warnings are not kept).
struct PackedMasks {
  int width = 0, height = 0;
  bool empty = true;
  std::vector<std::uint32_t> inside, contour;  ///< begin, end, begin, end, ...
};
PackedMasks pack_masks(const SliceMasks& m);
SliceMasks unpack_masks(const PackedMasks& p);

/// One label of a label image: its masks packed as pack_masks(slice_masks())
/// packs them (inside: == label; contour: mask_boundary() of it) and their
/// mask_bounds().
struct LabelMasks {
  std::uint32_t label = 0;
  PackedMasks masks;
  PixelBox bounds;
};

/// Every non-zero label of `image`, in increasing order, from one pass over
/// its pixels (the same masks as slice_masks() of each label in turn).
std::vector<LabelMasks> label_masks(const Grid2u32& image);

/// A label's inside runs (PackedMasks::inside) in one slice.
struct LabelRuns {
  std::uint32_t label = 0;
  const std::vector<std::uint32_t>* inside = nullptr;
};

/// The label image over `box` with one pixel of background around it (a mask
/// touching the image border is closed there, as the fields' crops are),
/// from every label's inside runs of a slice of `image_width` columns: the
/// image's own values where the runs are every non-zero label's.
Grid2u32 labels_around_box(const std::vector<LabelRuns>& runs, int image_width, const PixelBox& box);

/// Over a box of a label image (`labels`: labels_around_box()): inside the
/// labels' union, how much farther its edge is than the edge of the pixel's
/// own label (exact distances to the edges halfway between pixel centres),
/// else 0. Zero wherever a label meets only the background; the union's
/// field is its labels' plus this.
Grid2f union_healing(const Grid2u32& labels);

/// Bounding box of a slice's inside and contour pixels; empty if m.empty.
PixelBox mask_bounds(const SliceMasks& m);

/// Union of the slices' mask_bounds() plus margin, clipped; empty if all are.
PixelBox object_box(const std::vector<PixelBox>& bounds, int width, int height, int margin);

/// Where one slice's field must be exact (methods/columns/field_band.h): `needed`
/// (the values the splines and Marching Cubes read), `required` (needed grown
/// by the filter's reach: where the extension must have finished).
struct SliceBand {
  Grid2u8 needed, required;
};

}  // namespace isoloft::detail

namespace isoloft {

/// One slice of one object, as a method reads it (methods/method.h).
struct SliceInput {
  const detail::SliceMasks& masks;  ///< full-size contour and inside
  const Slice& slice;               ///< z, source, polygons (polyline input)
  PixelBox box;                     ///< the object's crop box: the field covers it
  InputKind kind = InputKind::Contours;
  int stack_width = 0;              ///< working grid width (fine polyline rasters)
  bool keep_stages = false;         ///< keep SliceField::mpu and distance (--dump-stages)
  /// If set: the field need only be exact there (methods/columns/field_band.h); elsewhere only its sign counts.
  const detail::SliceBand* band = nullptr;
};

/// A method's field for one slice over the crop box, positive inside, with
/// what it reports.
struct SliceField {
  Grid2f field;            ///< the slice's knot field (after any filter)
  bool fallback = false;   ///< too few points for a curve: exact pixel distances instead
  long sign_guarded = 0;   ///< pixels whose MPU sign the sign guard overruled
  MpuResult fit;           ///< curve-fitting methods: the fit's statistics
  OrientedPoints points;   ///< contour points and normals, crop coordinates
  Grid2f mpu, distance;    ///< kept only when asked (figures): raw MPU f, distance before the filter
  double t_mpu = 0, t_dist = 0, t_filter = 0;  ///< CPU seconds of the stages
};

}  // namespace isoloft

namespace isoloft::detail {

/// Gives every empty slice a field: a non-empty neighbour's field moved
/// 1 / cap_extent of the way to its cap_slice() for the gap (z: the slices'
/// heights, px; the lower of two), so the object closes in the gap like an
/// end cap; without one, as interp.isolated_empty says.
void fill_empty_slices(std::vector<Grid2f>& fields, const std::vector<double>& z, const PixelBox& box,
                       const InterpParams& interp);

/// min(-1, the lowest value of f): fold over the non-empty fields for the
/// value of an empty slice without a non-empty neighbour.
float most_negative(float so_far, const Grid2f& f);

/// -max(1, cap_depth): the highest value of an isolated empty slice (the
/// mesher's pad outside the caps).
float isolated_ceiling(const InterpParams& interp);

/// The fields an empty slice's field reads (null or empty: none, or not
/// read) and their distances from the next slice toward it (px).
struct EmptyNeighbours {
  const Grid2f* below = nullptr;   ///< slice k - 1
  const Grid2f* above = nullptr;   ///< slice k + 1
  const Grid2f* below2 = nullptr;  ///< slice k - 2 (IsolatedEmpty::Secant)
  const Grid2f* above2 = nullptr;  ///< slice k + 2 (IsolatedEmpty::Secant)
  double gap_below = 0, gap_above = 0, gap_below2 = 0, gap_above2 = 0;
};

/// One empty slice's field as fill_empty_slices() gives it. `lowest`: what
/// IsolatedEmpty::Lowest or Neighbours reads (most_negative() of all fields,
/// or of those within kIsolatedNeighbourSlices).
Grid2f empty_slice_field(const EmptyNeighbours& nb, float lowest, const PixelBox& box, const InterpParams& interp);

}  // namespace isoloft::detail
