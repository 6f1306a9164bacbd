// @file io/polylines.h
// @brief isoloft's polyline text format: closed planar contours per slice.
// Pixel units of the working grid (e.g. from a DICOM RT Structure Set):
//   # comment (a whole line or after the data)
//   isoloft-polylines 1   # magic + version, the first non-comment line
//   size 500 470          # grid width height, required, before any slice
//   pixel_size 0.8        # optional (default 1), before any slice
//   slice 0               # z of the contours below, strictly increasing
//   contour               # closed; >= 3 "x y" lines (column, row) follow,
//   12.5 40               #   within [-0.5, width-0.5] x [-0.5, height-0.5]
// Holes and islands by even-odd nesting; numbers in C locale.
// @warning A `slice` without contours is an empty slice (all outside).
// @warning A final point equal to the first (explicitly closed) is dropped.
#pragma once

#include <string>

#include "isoloft/core/slice_stack.h"

namespace isoloft {

/// A stack of kind Polylines, a Slice per `slice` (source = path, no image).
/// \throw InputError "path:line: problem" for a wrong magic or version, no
///        `size`, a bad number, a point outside the grid, a contour of < 3
///        points, z not increasing, data before a slice, an unknown keyword, no slices.
SliceStack read_polylines(const std::string& path);

/// Writes atomically, numbers in the shortest form that reads back exactly.
/// \throw ParamError unless kind is Polylines and the stack meets the reader's
///        rules; Error naming the path if writing fails.
void write_polylines(const std::string& path, const SliceStack& stack);

}  // namespace isoloft
