// The input of a reconstruction: parallel planar slices, each a raster image
// or a set of closed polygons, at known z. Units are pixels of the working
// grid; `pixel_size` is applied only by the writers (io/).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "isoloft/core/grid.h"
#include "isoloft/core/mesh.h"

namespace isoloft {

/// How to read the pixel values of a slice image.
enum class InputKind {
  Contours,  ///< white pixels (> half range) are contour curves
  Masks,     ///< white pixels are filled regions
  Labels,    ///< every distinct non-zero value is its own object
};

/// One closed polygon, vertices in pixel units (x = column, y = row); the
/// closing edge from back() to front() is implied.
struct Polygon {
  std::vector<Vec2d> points;
};

struct Slice {
  double z = 0.0;           ///< position in pixel units
  Grid2u32 image;           ///< raw values: gray level, or 0xRRGGBB for colour; empty for polylines
  std::vector<Polygon> polygons;  ///< closed contours (polyline input); even-odd nesting
  std::string source;       ///< file it came from, for error messages
};

struct SliceStack {
  int width = 0;   ///< working grid size in pixels
  int height = 0;
  std::uint32_t max_value = 255;  ///< full range of image values (255, 65535, 0xFFFFFF)
  double pixel_size = 1.0;        ///< physical size of one pixel (applied at output)
  bool polylines = false;         ///< slices carry polygons instead of images
  std::vector<Slice> slices;      ///< strictly increasing z
};

}  // namespace isoloft
