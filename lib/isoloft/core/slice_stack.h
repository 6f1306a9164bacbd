// @file core/slice_stack.h
// @brief The input of a reconstruction: parallel planar slices at known z.
// Each slice is a raster image or a set of closed polygons. Pixel units of the
// working grid (pixel (i, j) of slice k at (i, j, z_k)); `pixel_size` is
// applied only by the writers (io/).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "isoloft/core/grid.h"
#include "isoloft/core/mesh.h"
#include "isoloft/core/params.h"

namespace isoloft {

/// What the slices hold, and so how the pipeline reads them.
enum class InputKind {
  Contours,   ///< images: white pixels (> half range) are contour curves, inside by even-odd nesting
  Masks,      ///< images: white pixels are filled regions
  Labels,     ///< images: every distinct non-zero value is its own object
  Polylines,  ///< closed polygons per slice (Slice::polygons), inside by even-odd nesting
};

inline constexpr std::array<EnumName<InputKind>, 4> kInputKindNames{{{InputKind::Contours, "contours"},
                                                                     {InputKind::Masks, "masks"},
                                                                     {InputKind::Labels, "labels"},
                                                                     {InputKind::Polylines, "polylines"}}};
constexpr std::span<const EnumName<InputKind>> enum_names(InputKind) { return kInputKindNames; }

/// A closed polygon in pixel units (x column, y row), closing edge implied.
struct Polygon {
  std::vector<Vec2d> points;
};

struct Slice {
  double z = 0.0;           ///< position in pixel units
  Grid2u32 image;           ///< raw values: gray level, or 0xRRGGBB for colour; empty for polylines
  std::vector<Polygon> polygons;  ///< closed contours (polyline input); even-odd nesting
  std::string source;       ///< file it came from, for error messages
};

/// Where the working grid lies in DICOM patient space (LPS, mm): working
/// point p = (x, y, z) in pixels is at origin + axes * p. Known for volume
/// and RT Structure Set input; image and polyline input have none.
struct PatientFrame {
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();  ///< columns: mm per working pixel along x, y, z
  Vec3d origin = Vec3d::Zero();                        ///< patient position of working (0, 0, 0)
  [[nodiscard]] Vec3d to_patient(const Vec3d& p) const { return origin + axes * p; }
};

struct SliceStack {
  int width = 0;   ///< working grid size in pixels
  int height = 0;
  std::uint32_t max_value = 255;  ///< full range of image values (255, 65535, 0xFFFFFF)
  double pixel_size = 1.0;        ///< physical size of one pixel (applied at output)
  InputKind kind = InputKind::Contours;  ///< images of contours, masks or labels, or polygons
  std::optional<PatientFrame> patient;   ///< physical geometry, when the input has one
  std::vector<Slice> slices;      ///< strictly increasing z
  /// Lazy images: if set, slice k's image is load_image(k), read when the
  /// pipeline needs it (from worker threads, any order, maybe more than once)
  /// and Slice::image stays empty; memory then does not grow with the slices.
  std::function<Grid2u32(std::size_t k)> load_image;

  [[nodiscard]] bool has_polygons() const { return kind == InputKind::Polylines; }
};

}  // namespace isoloft
