// Exact-distance oracle for 2D signed distance fields (paper 2.2 check): the
// signed distance from every pixel centre to a set of closed polygons or
// zero-set segments, with the squared distance to each candidate segment
// computed exactly in CGAL's Exact_predicates_exact_constructions_kernel
// (Epeck, rational arithmetic) and inside/outside decided exactly by
// CGAL::bounded_side_2 (even-odd over all polygons). Only the final square
// root is rounded (<= 2 ulp). A field computed by isoloft (field/edt.h,
// field/narrow_band.h) is then compared with it pixel by pixel.
//
// Speed: a uniform bucket grid over the segments yields, per pixel, the few
// segments whose inexact (double) distance is within a rounding margin of the
// inexact minimum; only those are evaluated exactly. The pure brute-force twin
// (detail::) evaluates every segment exactly and must agree bit for bit.
//
// Units: pixels; pixel (i, j) of a grid is the point (x0 + i, y0 + j) (the
// pixel-centre convention of core/grid.h). Sign: positive inside.
//
// This header is CGAL-free (tests and the CLI include it); CGAL is confined to
// exact_distance.cpp.
#pragma once

#include <array>
#include <functional>
#include <limits>
#include <vector>

#include "isoloft/core/grid.h"
#include "isoloft/core/mesh.h"
#include "isoloft/core/slice_stack.h"

namespace isoloft {

/// A straight piece of a curve, end points in pixel units (the same type as
/// field/narrow_band.h's Segment2d).
using Segment2d = std::array<Vec2d, 2>;

/// Pixels of an exact field farther than `band` from every segment hold this
/// value (NaN: "not computed", skipped by compare_field()).
inline constexpr double kOutsideBand = std::numeric_limits<double>::quiet_NaN();

struct FieldErrorReport {
  double max_abs_error = 0;   ///< max |field - exact| over checked pixels, px
  double mean_abs_error = 0;  ///< mean |field - exact| over checked pixels, px
  int worst_x = -1, worst_y = -1;  ///< pixel of max_abs_error (-1 if none checked)
  double worst_field = 0, worst_exact = 0;  ///< the two values at the worst pixel
  long sign_errors = 0;  ///< pixels where field and exact distance have strictly opposite signs
  int first_sign_error_x = -1, first_sign_error_y = -1;  ///< first such pixel in row-major order
  long pixels_checked = 0;  ///< pixels with |exact| <= band
};

/// Exact signed distance to closed polygons: |d| = exact distance to the
/// nearest polygon edge, d > 0 where the pixel centre is inside an odd number
/// of polygons (bounded_side_2 == ON_BOUNDED_SIDE), d = 0 on an edge.
/// \param band pixels with |d| > band get kOutsideBand (infinity: all pixels).
/// \pre every polygon is simple (bounded_side_2's precondition); polygons may
///      nest or be disjoint.
/// \return a width x height grid.
/// \throw ParamError if width or height < 0, band < 0 or NaN, x0/y0 not finite.
/// \throw InputError if a polygon has fewer than 3 vertices or a non-finite vertex.
Grid2d exact_signed_distance(const std::vector<Polygon>& polygons, int width, int height, double x0 = 0,
                             double y0 = 0, double band = std::numeric_limits<double>::infinity());

/// Exact signed distance to unordered segments (e.g. NarrowBandResult::segments
/// or a marching-squares zero set), the sign taken from `inside` (1 = inside,
/// e.g. the samples of the implicit function > 0); the grid has inside's size.
/// With no segments every pixel is +-infinity (by its inside flag).
/// \throw ParamError as above; InputError if a segment end point is not finite.
Grid2d exact_signed_distance(const std::vector<Segment2d>& segments, const Grid2u8& inside, double x0 = 0,
                             double y0 = 0, double band = std::numeric_limits<double>::infinity());

/// Compares a computed signed distance field (positive inside) with the exact
/// one for the polygons at every pixel whose exact |d| <= band.
/// \throw as exact_signed_distance(); InputError if the field holds NaN.
FieldErrorReport compare_field(const Grid2f& field, const std::vector<Polygon>& polygons, double x0 = 0,
                               double y0 = 0, double band = std::numeric_limits<double>::infinity());

/// The same against segments with the sign from `inside` (of field's size).
/// \throw ParamError if inside and field differ in size; as above.
FieldErrorReport compare_field(const Grid2f& field, const std::vector<Segment2d>& segments, const Grid2u8& inside,
                               double x0 = 0, double y0 = 0,
                               double band = std::numeric_limits<double>::infinity());

/// Compares two fields given as grids (computed vs exact), skipping pixels
/// where `exact` is NaN (kOutsideBand). CGAL-free; used by compare_field().
/// \throw ParamError if sizes differ; InputError if `field` holds NaN at a checked pixel.
FieldErrorReport compare_grids(const Grid2f& field, const Grid2d& exact);

/// The zero level set of sampled f (pixel (i, j) at (x0 + i, y0 + j),
/// positive inside, f <= 0 outside) as closed polygons, by marching squares
/// (Lorensen & Cline 1987, 2D case): one vertex per grid edge whose end
/// samples differ in class, at the linear interpolation of the samples; saddle
/// cells are resolved by the value at the cell centre (refine(centre) if
/// given, else the mean of the four samples; > 0 joins the inside corners).
/// \param refine optional f as a function: each vertex is then moved to the
///        zero of refine on its edge by bisection (to ~1e-15 px), if refine's
///        signs at the edge ends agree with the samples.
/// \return closed loops (closing edge implied, orientation unspecified,
///         consecutive duplicate points removed; a loop collapsing to < 3
///         distinct points is dropped).
/// \throw InputError if f holds NaN, or the zero set leaves the grid (an open
///        chain; the message names the border pixel: pad the field).
std::vector<Polygon> zero_set_polygons(const Grid2f& f, double x0 = 0, double y0 = 0,
                                       const std::function<double(const Vec2d&)>& refine = {});

/// Edges of closed polygons as segments (closing edge included).
std::vector<Segment2d> polygon_segments(const std::vector<Polygon>& polygons);

namespace detail {

/// Exact unsigned distance from every pixel centre to the nearest segment,
/// candidates from the bucket grid; kOutsideBand beyond `band`; +infinity
/// everywhere if there are no segments.
Grid2d exact_unsigned_distance(const std::vector<Segment2d>& segments, int width, int height, double x0, double y0,
                               double band);
/// O(pixels x segments) twin: every segment evaluated exactly. Must equal
/// exact_unsigned_distance() bit for bit.
Grid2d exact_unsigned_distance_brute(const std::vector<Segment2d>& segments, int width, int height, double x0,
                                     double y0, double band);
/// Even-odd inside test at every pixel centre by CGAL::bounded_side_2 (1 =
/// inside an odd number of polygons; points on an edge count as outside).
Grid2u8 exact_inside(const std::vector<Polygon>& polygons, int width, int height, double x0, double y0);

}  // namespace detail
}  // namespace isoloft
