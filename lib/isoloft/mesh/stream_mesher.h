// @file mesh/stream_mesher.h
// @brief The z-interpolated field (paper 2.4) streamed into Marching Cubes (2.5).
// Each plane of the field (a ZInterpolator or ZStream) is padded by one pixel of `outside` (a
// surface cut by the crop border closes within a pixel beyond it), meshed and
// dropped: memory O(width x height) beyond the knots the field holds.
// Cell skipping, the contract of this unit: a cell whose four corners keep one
// known side of iso over both planes' knot intervals (ZInterpolator::sides(),
// layer_cells_to_visit; the pad has `outside`'s side) is skipped, and the mesh
// is bit for bit the one of visiting every cell (skip_cells = false, tested).
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
};

struct StreamMeshResult {
  TriMesh mesh;                ///< closed and oriented wherever the pad is outside
  double interp_seconds = 0;   ///< wall time evaluating the spline
  double mesh_seconds = 0;     ///< wall time in Marching Cubes
  long cells = 0;              ///< cells of all layers
  long cells_visited = 0;      ///< of those, the ones Marching Cubes looked at
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
  /// The mesh and counts; interp_seconds is the caller's.
  StreamMeshResult finish();

 private:
  class SideCache;
  const PlaneSource& field_;
  StreamMeshOptions options_;
  std::unique_ptr<SideCache> sides_;
  MarchingCubes builder_;
  double x0_, y0_;
  StreamMeshResult out_;
  std::vector<std::uint8_t> visit_;
  std::array<std::size_t, 2> visit_for_{std::size_t(-1), std::size_t(-1)};  // the interval pair visit_ was made for
  std::size_t k_prev_ = std::size_t(-1);
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

}  // namespace isoloft
