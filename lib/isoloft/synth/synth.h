// Synthetic slice stacks from analytic shapes (`isoloft synth`): the shape is
// cut by planes z = k * z_spacing and each cut is rasterized as a 1-pixel
// contour image or a filled mask.
//
// Contour rasterization: for every pair of 4-neighbouring pixels whose
// centres lie on opposite sides of the curve, the one closer to the curve
// (smaller |value|) is marked. The marked set is 8-connected along each curve,
// blocks every 4-connected path from inside to outside (so the even-odd fill
// recovers the inside exactly), and its pixel centres lie within ~0.5 px of the
// true curve (mean ~0.25 px): the pixelization error any binary input carries.
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
  /// Contours or Masks (images), or Polylines: closed polygons of the exact
  /// cut traced by marching squares on a grid of `polyline_step` pixels,
  /// vertices refined onto the surface (vertex error ~1e-9 px, chord error
  /// <= step^2 / (8 r)).
  InputKind kind = InputKind::Contours;
  double polyline_step = 0.5;  ///< pixels
};

struct SynthResult {
  SliceStack stack;            ///< of params.kind: images (0/255) or polygons, z = k * z_spacing
  std::unique_ptr<Shape> shape;  ///< moved so that slice k is at z = k * z_spacing
  nlohmann::json description;  ///< {"shape": ..., "stack": {...}}: what `isoloft eval --truth` reads
};

/// Cuts `shape` (in pixel units) by planes; the stack covers every plane that
/// meets the shape, starting first_offset spacings above its bottom.
/// \throw ParamError if size < 8, z_spacing <= 0, or the shape leaves the image.
SynthResult synthesize(const Shape& shape, const SynthParams& params);

/// Marks the contour pixels of an implicit slice f (positive inside), see above.
Grid2u8 rasterize_implicit_contour(const Grid2f& f);

/// Closed polygons of the zero set of f(x, y) (positive inside) over
/// [0, width-1] x [0, height-1], traced on a grid of `step` pixels.
/// \pre f < 0 on the border of that rectangle (closed curves).
std::vector<Polygon> implicit_slice_polygons(const std::function<double(const Vec2d&)>& f, int width, int height, double step);

}  // namespace isoloft
