// @file field3d/image_sections.h
// @brief Label-image sections as the polyline sections field3d's solver
// reads (issue 35 item 2, pixel input): per label, the traced sub-pixel
// boundary of its pixels (contour/mask_curve.h, the default method's) as
// closed in-plane polylines. The solver then puts f = 0 samples on that
// boundary and the clamped in-plane signed distance to it over the whole
// plane, so the boundary between pixels of different labels is where the
// surface passes and inside/outside is known everywhere on the plane.
// Every traced vertex lies strictly between an inside and an outside pixel
// centre, so the polylines' even-odd inside holds exactly the label's
// pixel centres.
// Units: in-plane millimetres (Section::pixel_size per pixel).
// @warning A label absent from an image section leaves it without contours:
// the solver then takes the whole plane as outside (what the image says).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "isoloft/contour/mask_curve.h"
#include "isoloft/core/grid.h"
#include "isoloft/core/mesh.h"
#include "isoloft/core/section.h"
#include "isoloft/field3d/field3d.h"

namespace isoloft {

/// The grid of a pixel input has this many cells per pixel along
/// each axis (the finest pixel of all sections): the traced boundary lies
/// within a pixel of the centres it separates, so the trilinear field needs
/// cells no larger than a pixel to follow it; with one cell per pixel the
/// surface drew every input pixel of the analytic mask kit (input-slice
/// Dice 1.0000 on all 18 rows, docs/decisions.md: label-image sections in
/// field3d). Coarser grids were not measured.
inline constexpr double kImageCellsPerPixel = 1.0;

/// The traced boundary of `inside` (1 = inside) as closed polylines in
/// pixel units (pixel (x, y)'s centre at (x, y)), inside by even-odd
/// nesting; beyond the image everything is outside, so every loop closes.
/// \throw ParamError for MaskCurveParams out of range.
/// @warning An empty mask gives no loop.
std::vector<std::vector<Vec2d>> traced_loops(const Grid2u8& inside, const MaskCurveParams& params = {});

/// The 1/2 level of `inside` smoothed by a Gaussian of `sigma` px
/// (mask_curve.h smoothed_mask) as closed polylines, as traced_loops():
/// smooth, but a pixel centre near a corner or in a feature thinner than
/// about 2 sigma may fall on the wrong side (the solver's sign constraints
/// put it back, Field3dParams::pixel_signs).
/// @warning An empty mask, or one whose every pixel smooths below 1/2, gives no loop.
std::vector<std::vector<Vec2d>> smoothed_loops(const Grid2u8& inside, double sigma);

/// smoothed_loops() for sigma > 0, else traced_loops().
std::vector<std::vector<Vec2d>> boundary_loops(const Grid2u8& inside, const MaskCurveParams& params, double sigma);

/// How traced_section() turns a label image into the solver's section.
struct PixelBoundary {
  double sigma = 0;         ///< px; 0: traced_loops(), > 0: smoothed_loops() (Field3dParams::pixel_sigma)
  bool keep_image = false;  ///< keep the label image: the solver's sign constraints (Field3dParams::pixel_signs)
};

/// `section` with its label image replaced by the boundary of `label`'s
/// pixels (in-plane mm, label `label`, even-odd; `boundary` says which, and
/// whether the image stays beside it); a polyline section is returned as it is.
/// \throw InputError naming Section::source for a pixel size that is not
///        positive and finite.
Section traced_section(const Section& section, std::uint32_t label, const MaskCurveParams& params = {},
                       const PixelBoundary& boundary = {});

/// Every section through traced_section(), side by side.
std::vector<Section> traced_sections(const std::vector<Section>& sections, std::uint32_t label,
                                     const MaskCurveParams& params = {}, const PixelBoundary& boundary = {});

/// The PixelBoundary that `params` asks for (pixel_sigma, pixel_signs).
inline PixelBoundary pixel_boundary(const Field3dParams& params) { return {params.pixel_sigma, params.pixel_signs}; }

/// `params` for pixel input: band and contour_weight from pixel_band and
/// pixel_contour_weight, and the resolution raised so that the solver's grid
/// over `traced` (the box reconstruct_sections() builds around `label`'s
/// contours) has kImageCellsPerPixel cells per `pixel_size` mm
/// (pixel_resolution()). docs/decisions.md: field3d pixel input: sign constraints at pixel centres.
Field3dParams pixel_params(const std::vector<Section>& traced, std::uint32_t label, double pixel_size,
                           Field3dParams params);

/// `params` with the pixel input's rows in place of the general ones: band
/// from pixel_band, contour_weight from pixel_contour_weight, plane_slope
/// from pixel_slope, band_per_gap from pixel_band_per_gap,
/// plane_weight_per_gap from pixel_plane_weight_per_gap, sign_guard from
/// pixel_sign_guard (the grid's resolution is pixel_resolution()'s).
Field3dParams pixel_rows(Field3dParams params);

/// pixel_params()'s resolution for a grid over `box` (world mm, low and high
/// corners, before the margins: box_margins() over `sections`):
/// params.pixel_resolution when > 0, else
/// kImageCellsPerPixel cells per `pixel_size` (at least 16, at most 1024;
/// params.resolution for an empty box). field3d.resolution does not floor
/// it: a 32^3 annotated sphere took 10.5 s at the default 96 against 0.2 s
/// at a cell per voxel, with the same properties.
int pixel_resolution(const std::array<Vec3d, 2>& box, double pixel_size, const std::vector<Section>& sections,
                     const Field3dParams& params);

/// The pixels of a `width` x `height` image on `pose` (pixel (x, y)'s centre
/// at pose.to_world({x pixel_size, y pixel_size})) whose centres lie inside
/// the closed mesh's section by that plane (mesh/plane_cut.h cut_mesh, then
/// the even-odd rule): what the surface draws on an input section, to
/// compare with the drawn pixels.
/// @warning An open mesh's chains are dropped (cut_mesh): no meaning then.
Grid2u8 section_pixels(const TriMesh& mesh, const PlanePose& pose, double pixel_size, int width, int height);

/// Dice 2 |a and b| / (|a| + |b|) of two masks of one size (1 when both are empty).
double dice(const Grid2u8& a, const Grid2u8& b);

}  // namespace isoloft
