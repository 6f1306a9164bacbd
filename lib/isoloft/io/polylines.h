// isoloft's polyline text format: planar closed contours per slice, the
// vector alternative to slice images (e.g. converted from a DICOM RT
// Structure Set). All coordinates are in pixel units of the working grid
// (pixel-centre convention: pixel (i, j) covers [i-0.5, i+0.5] x [j-0.5, j+0.5]).
//
//   # comments start with '#' (whole line or after the data), blank lines ignored
//   isoloft-polylines 1      # magic + version: the first non-comment line
//   size 500 470             # working grid width height in pixels (integers >= 1), required
//   pixel_size 0.8           # optional (default 1): physical units per pixel, > 0
//   slice 0                  # z of the following contours, pixel units; strictly
//                            #   increasing through the file, may be non-uniform
//   contour                  # a closed contour; the last point joins the first
//   12.5 40                  # one "x y" point per line (x = column, y = row)
//   ...                      #   at least 3 points per contour, each inside
//                            #   [-0.5, width-0.5] x [-0.5, height-0.5]
//   contour                  # several contours per slice; holes and islands by
//   ...                      #   even-odd nesting, orientation ignored
//   slice 8
//   ...
//
// `size` and `pixel_size` come before the first `slice`. A `slice` with no
// contours is an empty slice (everything outside). A contour's final point
// equal to its first (explicitly closed) is dropped. Numbers are decimal
// (C locale, e.g. 12, -3.5, 1e-3); keywords are lower case, one per line.
// Errors name the file and line: "file.txt:17: expected two numbers".
#pragma once

#include <string>

#include "isoloft/core/slice_stack.h"

namespace isoloft {

/// Read a polyline file into a stack of kind Polylines: one Slice per
/// `slice` line (z and polygons from the file, source = path, no image),
/// width/height from `size`, pixel_size from `pixel_size` (default 1),
/// max_value left at its default.
/// \throw InputError with what() "path:line: problem" for: missing or wrong
/// magic/version, missing `size`, malformed numbers, a point outside the grid,
/// a contour with fewer than 3 points, z not strictly increasing, points or
/// contours before a slice, unknown keywords, no slices.
SliceStack read_polylines(const std::string& path);

/// Write `stack` in the format above (atomically), numbers in the shortest
/// form that reads back to the same double, so read_polylines returns the
/// same stack.
/// \pre stack.kind == Polylines, width/height >= 1, z strictly increasing, every
/// polygon has >= 3 points, all inside the grid (as the reader requires).
/// \throw ParamError if a precondition fails; Error naming the path if writing fails.
void write_polylines(const std::string& path, const SliceStack& stack);

}  // namespace isoloft
