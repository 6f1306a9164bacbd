// @file synth/synth.h
// @brief Synthetic slice stacks cut from analytic shapes (`isoloft synth`).
// Cuts at z = k z_spacing as contour images, masks or polygons. Of each pair of
// 4-neighbours on opposite sides of the curve the one of smaller |value| is
// marked: an 8-curve the even-odd fill inverts exactly, centres within ~0.5 px
// of the curve (mean ~0.25 px), the error of any binary input.
#pragma once

#include <functional>
#include <nlohmann/json.hpp>
#include <string>

#include "isoloft/core/slice_stack.h"
#include "isoloft/synth/shapes.h"

namespace isoloft {

struct SynthParams {
  int size = 128;            ///< image width and height, pixels
  double z_spacing = 8.0;    ///< slice spacing in pixels (the z ratio, e.g. 8:1)
  double first_offset = 0.37;  ///< first cut this many spacings above the shape's bottom (avoids cutting at a pole)
  /// Contours, Masks, or Polylines (the cut traced on a polyline_step grid).
  InputKind kind = InputKind::Contours;
  double polyline_step = 0.5;  ///< pixels
};

struct SynthResult {
  SliceStack stack;            ///< of params.kind: images (0/255) or polygons, z = k * z_spacing
  std::unique_ptr<Shape> shape;  ///< moved so that slice k is at z = k * z_spacing
  nlohmann::json description;  ///< {"shape": ..., "stack": {...}}: what `isoloft eval --truth` reads
};

/// Cuts `shape` by every plane that meets it, from first_offset spacings up.
/// \throw ParamError if size < 8, z_spacing <= 0, kind is Labels, the shape
///        leaves the image, or fewer than 2 planes meet it.
SynthResult synthesize(const Shape& shape, const SynthParams& params);

/// Cuts `shape` where it lies at the heights `z` (increasing) into
/// width x height images (or polygons) of params.kind; params.size,
/// z_spacing and first_offset are not read.
/// \throw ParamError if a size is < 8, kind is Labels, the shape leaves the
///        image, or z has fewer than 2 heights.
SynthResult synthesize_at(const Shape& shape, const std::vector<double>& z, int width, int height, const SynthParams& params);

/// The contour pixels of an implicit slice f (positive inside).
Grid2u8 rasterize_implicit_contour(const Grid2f& f);

/// Closed polygons of f = 0 (positive inside) over [0, width-1] x [0, height-1].
/// \pre f < 0 on the border of that rectangle.
std::vector<Polygon> implicit_slice_polygons(const std::function<double(const Vec2d&)>& f, int width, int height, double step);

}  // namespace isoloft
