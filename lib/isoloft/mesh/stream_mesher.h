// @file mesh/stream_mesher.h
// @brief The z-interpolated field (paper 2.4) streamed into Marching Cubes (2.5).
// Each plane of the field (a ZInterpolator or ZStream) is padded by one pixel of `outside` (a
// surface cut by the crop border closes within a pixel beyond it), meshed and
// dropped: memory O(width x height) beyond the knots the field holds.
// Cell skipping, the contract of this unit: a cell whose four corners keep one
// known side of iso over both planes' knot intervals (ZInterpolator::sides(),
// layer_cells_to_visit; the pad has `outside`'s side) is skipped, and the mesh
// is bit for bit the one of visiting every cell (skip_cells = false, tested).
// Likewise only the pixels of a plane that are corners of cells visited
// below or above it are evaluated (needed(); unless on_plane sees the planes).
// Sign convention: positive inside; a sample is inside iff value > iso.
// @warning Layers more than one knot interval apart (slices denser than the
// plane step) visit every cell; splines that overshoot (all but monotone and
// linear) skip less (sides() widens the knots by their overshoot bound).
#pragma once

#include <array>
#include <functional>
#include <memory>
#include <vector>

#include "isoloft/core/grid.h"
#include "isoloft/core/mesh.h"
#include "isoloft/interp/spline.h"
#include "isoloft/interp/z_stream.h"
#include "isoloft/mesh/marching_cubes.h"

namespace isoloft {

/// Knots must lie this far beyond iso for a known side, px: far above the
/// float rounding of a spline value, far below a pixel (docs/decisions.md).
inline constexpr float kSideMargin = 1e-2f;

/// Called with every padded plane (x0, y0: its pixel (0, 0)), z, index, count.
using PlaneCallback = std::function<void(const Grid2f& plane, double x0, double y0, double z, int index, int count)>;

struct StreamMeshOptions {
  float outside = -1.0f;  ///< value of the one-pixel pad (must be outside: <= iso)
  bool skip_cells = true;  ///< false: visit every cell (the oracle of the skipping)
  PlaneCallback on_plane;  ///< optional
  std::function<void(long done, long total)> progress;  ///< optional, once per plane
  MeshSpill* spill = nullptr;  ///< optional: the mesh goes there as it grows (finish() returns it empty)
  /// Triangles to make room for at the start (MarchingCubes::reserve; 0:
  /// none; unused with a spill): a large mesh grown by copies faults in
  /// fresh pages for each, its room untouched beyond the mesh costs none.
  std::size_t reserve_triangles = 0;
};

struct StreamMeshResult {
  TriMesh mesh;                ///< closed and oriented wherever the pad is outside
  double interp_seconds = 0;   ///< wall time evaluating the spline
  double mesh_seconds = 0;     ///< wall time in Marching Cubes
  long cells = 0;              ///< cells of all layers
  long cells_visited = 0;      ///< of those, the ones Marching Cubes looked at
  long pixels = 0;             ///< pixels of all planes
  long pixels_evaluated = 0;   ///< of those, the ones the spline was evaluated at
};

/// Marching Cubes of one z-interpolated field fed plane by plane, so that
/// several fields can be meshed in lockstep (e.g. a partition of labels):
/// each plane padded by `outside`, cells skipped by `field`'s sides()
/// (the contract above), the mesh at finish().
class StreamMesher {
 public:
  /// \throw ParamError if `outside` is above mc.iso.
  StreamMesher(const PlaneSource& field, double x0, double y0, const MarchingCubesParams& mc, StreamMeshOptions options = {});
  ~StreamMesher();
  StreamMesher(const StreamMesher&) = delete;
  StreamMesher& operator=(const StreamMesher&) = delete;
  /// The next plane (field.width() x field.height()) at z, in knot interval k,
  /// of `count` planes in all (for progress and on_plane).
  void add(const Grid2f& plane, double z, std::size_t k, long count);
  /// Before add(): the pixels of the next plane (interval k) Marching Cubes
  /// may read, given whether the plane after it is in interval k too; nullptr:
  /// all of them (the first plane, a layer visiting every cell, on_plane set).
  /// add() then takes only these pixels of its plane (the others unread).
  const PixelRuns* needed(std::size_t k, bool next_in_interval);
  /// The mesh and counts; interp_seconds is the caller's.
  StreamMeshResult finish();

 private:
  class SideCache;
  bool layer_visit(std::size_t k);  // visit_ for the layer below the next plane; false: visit every cell
  const PixelRuns* needed_runs(std::size_t k, bool next_in_interval);
  const PlaneSource& field_;
  StreamMeshOptions options_;
  std::unique_ptr<SideCache> sides_;
  MarchingCubes builder_;
  double x0_, y0_;
  StreamMeshResult out_;
  std::vector<std::uint8_t> visit_;
  std::array<std::size_t, 2> visit_for_{std::size_t(-1), std::size_t(-1)};  // the interval pair visit_ was made for
  long visited_ = 0;  // cells visit_ visits
  Grid2f spare_;      // a padded plane Marching Cubes is done with, refilled by the next add()
  std::size_t k_prev_ = std::size_t(-1);
  PixelRuns needed_;
  std::array<std::size_t, 2> needed_for_{std::size_t(-1), std::size_t(-1)};  // the interval pair needed_ was made for
  const PixelRuns* next_needed_ = nullptr;  // what needed() gave for the next plane: all Marching Cubes reads of it
};

/// Marching Cubes of `field` on the planes z = `planes` (increasing, within
/// the field's z range); field pixel (i, j) is at (x0 + i, y0 + j). The field
/// is read in plane order (PlaneSource::reach), so a ZStream's knots are
/// pulled as the planes need them; interp_seconds excludes reach().
/// \throw ParamError if planes has fewer than 2 entries, is not increasing,
///        or `outside` is above mc.iso.
StreamMeshResult mesh_interpolated_field(PlaneSource& field, const std::vector<double>& planes, double x0, double y0,
                                         const MarchingCubesParams& mc, const StreamMeshOptions& options = {});
StreamMeshResult mesh_interpolated_field(const ZInterpolator& field, const std::vector<double>& planes, double x0,
                                         double y0, const MarchingCubesParams& mc, const StreamMeshOptions& options = {});

/// z_begin + j step up to the cap slice z_end, the last moved onto z_end.
/// \throw ParamError if step <= 0 or z_end <= z_begin.
std::vector<double> sample_planes(double z_begin, double z_end, double step);

/// The Marching Cubes planes over knots z (end caps included, increasing):
/// sample_planes(z.front(), z.back(), z_step), or with planes_on_slices a
/// z_step grid through the first slice z[1] (every slice when the spacing is
/// a multiple of z_step) from the last plane at or below z.front() to the
/// first at or above z.back() (beyond the end knots a field holds their
/// values). If a slice misses that grid, planes still run through every
/// slice: evenly spaced slices get the largest step below z_step dividing
/// their spacing (one step throughout), uneven ones each knot interval split
/// into equal steps of at most z_step.
std::vector<double> mesh_planes(const std::vector<double>& z, const InterpParams& interp);

}  // namespace isoloft
