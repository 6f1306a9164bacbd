// @file mesh/marching_cubes.h
// @brief Streaming Marching Cubes (Lorensen & Cline 1987; paper 2.5).
// The iso level set of a field given plane by plane in increasing z, as a
// welded mesh; two planes and their edge-vertex maps are held. Sign convention:
// positive inside, inside iff value > iso (zeros are outside); triangles
// counter-clockwise seen from outside; a vertex per crossed edge. Case table
// generated on first use (docs/decisions.md: generated case table): face
// segments never connect inside corners across the diagonal, are directed with
// the outside on their left, and each loop gets the least-diagonal
// triangulation never joining two vertices of one face; hence a closed,
// oriented 2-manifold whenever the outermost samples are outside.
// @warning Inside samples on the outermost planes or border leave the mesh
// open there (pad with outside, as mesh/stream_mesher.h does).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "isoloft/core/grid.h"
#include "isoloft/core/mesh.h"
#include "isoloft/core/params.h"
#include "isoloft/mesh/mesh_spill.h"

namespace isoloft {

/// Least fraction of an edge between a vertex and its ends (docs/decisions.md).
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

/// Streaming builder: add_plane() per plane in increasing z, then finish().
/// Triangles a spilling builder holds at most past a layer (12 bytes each,
/// about as many vertices): 64 Ki keeps ~1 MB per builder, 50 labels of a
/// partition ~60 MB, against their whole meshes (1 GB on the large stack).
inline constexpr std::size_t kSpillTriangles = std::size_t(1) << 16;

class MarchingCubes {
 public:
  /// Planes of width x height samples at (x0 + i, y0 + j), pixel units.
  /// \throw ParamError if width or height < 1, or x0, y0, iso are not finite.
  MarchingCubes(int width, int height, double x0 = 0, double y0 = 0, MarchingCubesParams params = {});

  /// Adds the plane at z (any spacing) and triangulates the layer below it,
  /// skipping cells whose `active` byte ((width - 1) x (height - 1), rows) is 0.
  /// \throw ParamError for a wrong size of values or active, or z not finite and
  ///        above the previous; InputError naming a non-finite value.
  /// `replaced`, if given, receives the plane before the previous one (its
  /// buffer to refill: empty until two planes are added).
  /// @warning A skipped cell must not hold the surface, or the mesh opens there.
  void add_plane(Grid2f values, double z, const std::vector<std::uint8_t>* active = nullptr, Grid2f* replaced = nullptr);

  /// The mesh (pixel units); resets the builder. Fewer than 2 planes: empty.
  /// With a spill: the mesh is in the spill, and finish() returns it empty.
  TriMesh finish();

  /// From now on the mesh goes to `spill` in pieces of at least `piece`
  /// triangles, one per layer that passes it (vertex ids count what the
  /// spill holds); nullptr: kept.
  void spill_into(MeshSpill* spill, std::size_t piece = kSpillTriangles) {
    spill_ = spill;
    spill_piece_ = piece;
  }

  /// Room for a mesh of about `triangles` (and half as many vertices), so
  /// that it is not copied as it grows; beyond it the arrays grow as usual.
  void reserve(std::size_t triangles);

  [[nodiscard]] int planes_added() const { return planes_; }

 private:
  void triangulate_layer(const Grid2f& top, double z_top, const std::vector<std::uint8_t>* active);

  int width_, height_;
  double x0_, y0_;
  MarchingCubesParams params_;
  int planes_ = 0;
  Grid2f prev_;          // values of the previous plane
  double prev_z_ = 0.0;  // its z
  // Vertex per grid edge or -1 (x, y edges of both planes; z edges between).
  std::vector<std::int32_t> xedge_bottom_, yedge_bottom_, xedge_top_, yedge_top_, zedge_;
  // Entries set in each array (cleared one by one); cube edge e is in kEdgeArray[e].
  enum EdgeArray : std::size_t { kXBottom, kXTop, kYBottom, kYTop, kZ };
  static constexpr std::array<std::size_t, 12> kEdgeArray{kXBottom, kXBottom, kXTop, kXTop, kYBottom, kYBottom,
                                                          kYTop,    kYTop,    kZ,    kZ,    kZ,       kZ};
  std::array<std::vector<std::int32_t*>, 5> set_;
  TriMesh mesh_;
  MeshSpill* spill_ = nullptr;
  std::size_t spill_piece_ = kSpillTriangles;
  std::size_t spilled_vertices_ = 0;  // vertex ids below this are in spill_
};

/// Cells to visit: all but those whose four corners share one known side
/// (ZInterpolator::sides()) in both planes. \throw ParamError unless the maps
/// are of one size, at least 1 x 1.
void layer_cells_to_visit(const Grid2<std::int8_t>& bottom, const Grid2<std::int8_t>& top,
                          std::vector<std::uint8_t>& visit);

/// Marching Cubes over a whole stack (the streaming builder); no planes: empty.
/// \throw ParamError if planes.size() != z.size(); as MarchingCubes::add_plane.
TriMesh marching_cubes(const std::vector<Grid2f>& planes, const std::vector<double>& z, double x0 = 0, double y0 = 0,
                       MarchingCubesParams params = {});

namespace detail {
/// Corner c at (c & 1, c >> 1 & 1, c >> 2 & 1); edges 0-3 along x, 4-7 y, 8-11 z.
inline constexpr std::array<std::array<int, 2>, 12> kCubeEdgeCorners{{{0, 1}, {2, 3}, {4, 5}, {6, 7},  //
                                                                      {0, 2}, {1, 3}, {4, 6}, {5, 7},  //
                                                                      {0, 4}, {1, 5}, {2, 6}, {3, 7}}};

/// Triangles (cube edge ids, output orientation) for inside_mask (bit c: corner c inside).
const std::vector<std::array<std::int8_t, 3>>& mc_case_triangles(int inside_mask);
}  // namespace detail

}  // namespace isoloft
