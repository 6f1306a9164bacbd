// Marching Cubes (Lorensen & Cline 1987, "Marching Cubes: A High Resolution 3D
// Surface Construction Algorithm"), paper 2.5: extracts the zero level set of
// the interpolated distance field as a welded triangle mesh. Streaming: planes
// arrive one at a time in increasing z, so only two planes and their
// edge->vertex maps are held (memory O(width * height)).
//
// Conventions
//  - The field is positive inside: a sample is inside iff value > iso
//    (strictly); value <= iso is outside, so exact zeros are outside.
//  - Triangles are counter-clockwise seen from outside: normals point toward
//    decreasing field.
//  - One vertex per crossed grid edge, at the linear-interpolation root
//    t = (iso - f0) / (f1 - f0), clamped to [kMinEdgeFraction, 1 - kMinEdgeFraction].
//
// Case table: not copied from the literature but generated on first use for
// all 256 corner configurations:
//  1. On every cube face the edge crossings are joined into segments. Ambiguous
//     faces (two diagonally opposite inside corners) use the fixed rule "inside
//     corners are never connected across a face diagonal": each inside corner
//     is cut off by its own segment. The rule depends only on the four face
//     values, so both cubes sharing a face produce the same segments.
//  2. Segments are directed so that, seen from outside the cube, the outside
//     part of the face is on their left; the two cubes sharing a face then
//     traverse each shared segment in opposite directions.
//  3. Segments chain into closed, vertex-disjoint loops (each crossed edge is
//     on exactly two faces of the cube). Each loop is triangulated by the
//     minimum-total-diagonal-length triangulation (on edge midpoints) that
//     never joins two vertices lying on a common cube face: such a diagonal
//     could also be chosen by the neighbouring cube and then be shared by four
//     triangles.
// Hence, whenever all outermost samples of the volume are outside, the output
// is a closed, consistently oriented 2-manifold (every edge in exactly two
// triangles with opposite directions, every vertex star a single disk).
// Ambiguity inside a cube needs no special handling for this guarantee.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "isoloft/core/grid.h"
#include "isoloft/core/mesh.h"
#include "isoloft/core/params.h"

namespace isoloft {

/// Smallest fraction of a grid edge between a vertex and either end of the
/// edge. Fields computed from contour pixels have exact zeros at grid points;
/// without the clamp the crossings of all edges meeting at such a point would
/// coincide and give zero-area triangles. With it, distinct grid edges give
/// distinct vertices and no triangle has three collinear vertices, as long as
/// coordinates stay below 2048 px (float spacing <= 1.2e-4 px there). Moves a
/// vertex by at most 1e-4 edge lengths.
inline constexpr double kMinEdgeFraction = 1e-4;

struct MarchingCubesParams {
  float iso = 0.0f;
};

template <>
inline const ParamTable<MarchingCubesParams>& params_table<MarchingCubesParams>() {
  static const ParamTable<MarchingCubesParams> t({
      field("iso", &MarchingCubesParams::iso, "px", "level of the interpolated signed distance extracted (paper 2.5)"),
  });
  return t;
}

/// Streaming Marching Cubes builder: add_plane() for every plane in increasing
/// z, then finish().
class MarchingCubes {
 public:
  /// Planes are width x height samples at x = x0 + i, y = y0 + j (pixel units).
  /// \throw ParamError if width or height < 1, or x0, y0, iso are not finite.
  MarchingCubes(int width, int height, double x0 = 0, double y0 = 0, MarchingCubesParams params = {});

  /// Adds the plane at `z` and triangulates the cube layer between it and the
  /// previous plane. Planes need not be evenly spaced. With `active` (one
  /// byte per cell of the layer, (width - 1) x (height - 1), row by row),
  /// cells marked 0 are skipped: the caller knows their corners lie on one
  /// side of iso (e.g. ZInterpolator::sides()), so the mesh is the same.
  /// \pre values.width == width, values.height == height, all values finite.
  /// \throw ParamError if the size is wrong (of values or active) or z is not
  ///        finite and strictly greater than the previous plane's z;
  ///        InputError naming the pixel if a value is not finite.
  void add_plane(Grid2f values, double z, const std::vector<std::uint8_t>* active = nullptr);

  /// Returns the mesh (pixel units, welded) and resets the builder so it can
  /// take a new volume of the same size.
  TriMesh finish();

  [[nodiscard]] int planes_added() const { return planes_; }

 private:
  void triangulate_layer(const Grid2f& top, double z_top, const std::vector<std::uint8_t>* active);

  int width_, height_;
  double x0_, y0_;
  MarchingCubesParams params_;
  int planes_ = 0;
  Grid2f prev_;          // values of the previous plane
  double prev_z_ = 0.0;  // its z
  // Vertex index per grid edge, -1 if not yet created. x edges: (width-1) x
  // height, y edges: width x (height-1), of the previous (bottom) and current
  // (top) plane; z edges: width x height between them.
  std::vector<std::int32_t> xedge_bottom_, yedge_bottom_, xedge_top_, yedge_top_, zedge_;
  // The entries set in each of those arrays, cleared one by one instead of
  // whole arrays (the surface meets a small part of the cells); cube edge e
  // is in array kEdgeArray[e] (edge order of kCubeEdgeCorners).
  enum EdgeArray : std::size_t { kXBottom, kXTop, kYBottom, kYTop, kZ };
  static constexpr std::array<std::size_t, 12> kEdgeArray{kXBottom, kXBottom, kXTop, kXTop, kYBottom, kYBottom,
                                                          kYTop,    kYTop,    kZ,    kZ,    kZ,       kZ};
  std::array<std::vector<std::int32_t*>, 5> set_;
  TriMesh mesh_;
};

/// The cells of a layer add_plane() must visit, given for each of its two
/// planes the side of iso every pixel is known to be on (+1 above, -1 below,
/// 0 unknown; e.g. ZInterpolator::sides() over the planes' knot intervals):
/// all but those whose four corner pixels have one known side, the same in
/// both planes. One byte per cell, (width - 1) x (height - 1), row by row.
/// \pre bottom and top are the same size, at least 1 x 1.
void layer_cells_to_visit(const Grid2<std::int8_t>& bottom, const Grid2<std::int8_t>& top,
                          std::vector<std::uint8_t>& visit);

/// Marching Cubes over a whole stack of planes (convenience wrapper of the
/// streaming builder).
/// \pre planes all of one size, z strictly increasing, values finite.
/// \throw ParamError if planes.size() != z.size(), sizes differ, or as
///        MarchingCubes::add_plane.
TriMesh marching_cubes(const std::vector<Grid2f>& planes, const std::vector<double>& z, double x0 = 0, double y0 = 0,
                       MarchingCubesParams params = {});

namespace detail {
/// Cube corner c (0..7) is at offset (c & 1, (c >> 1) & 1, (c >> 2) & 1).
/// Cube edge e (0..11) joins corners kCubeEdgeCorners[e][0] < [1]:
/// 0-3 along x, 4-7 along y, 8-11 along z.
inline constexpr std::array<std::array<int, 2>, 12> kCubeEdgeCorners{{{0, 1}, {2, 3}, {4, 5}, {6, 7},  //
                                                                      {0, 2}, {1, 3}, {4, 6}, {5, 7},  //
                                                                      {0, 4}, {1, 5}, {2, 6}, {3, 7}}};

/// Triangles (as cube edge ids, in output orientation) for the corner
/// configuration `inside_mask` (bit c set = corner c inside).
const std::vector<std::array<std::int8_t, 3>>& mc_case_triangles(int inside_mask);
}  // namespace detail

}  // namespace isoloft
