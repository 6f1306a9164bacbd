// @file objects/result.h
// @brief What reconstruct() returns per object and per run (mesh, checks,
// fit statistics, stage times, warnings), what it reports before the work
// (WorkEstimate) and the hooks a caller gives it (ReconstructOptions).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "isoloft/core/grid.h"
#include "isoloft/core/mesh.h"
#include "isoloft/eval/point_mesh.h"
#include "isoloft/field3d/field3d.h"
#include "isoloft/fit/mpu.h"
#include "isoloft/mesh/mesh_check.h"

namespace isoloft {

class MeshSpill;

struct FitStats {
  long points = 0, leaves = 0, leaves_over_tol = 0;
  long fallback_slices = 0;    ///< slices with too few points for a curve (exact pixel distances used)
  long sign_guarded_pixels = 0;  ///< pixels whose MPU sign the sign guard overruled (ReconstructParams::sign_guard)
  long sign_guarded_slices = 0;  ///< slices with at least one such pixel
  int max_depth_reached = 0;
  double max_local_error = 0;  ///< px (Taubin distance)
};

struct StageTimes {
  // Wall seconds, summed over objects (objects run side by side: their sum
  // can exceed the run's wall time).
  double contour = 0, mpu = 0, dist = 0, filter = 0, interp = 0, mesh = 0, decimate = 0;
  [[nodiscard]] double total() const { return contour + mpu + dist + filter + interp + mesh + decimate; }
  StageTimes& operator+=(const StageTimes& o) {
    contour += o.contour, mpu += o.mpu, dist += o.dist, filter += o.filter;
    interp += o.interp, mesh += o.mesh, decimate += o.decimate;
    return *this;
  }
};

struct ObjectResult {
  std::uint32_t label = 0;     ///< label value (labels input); 0 otherwise
  TriMesh mesh;                ///< closed, outward-oriented, pixel units (possibly empty: empty_reason)
  std::string empty_reason;    ///< why the mesh has no triangles ("" if it has some)
  MeshCheck check;
  /// run_jobs(), RT Structure Set ROIs: how far the input's contour vertices
  /// lie from the mesh (working pixels): the geometric error of the working
  /// grid the reader chose.
  std::optional<DistanceSummary> contour_distance;
  /// run_jobs(), polygon inputs: the closed surface's volume above the planes
  /// the volume table clips at (run/volume_table.h clipped_volumes()), px^3;
  /// empty until computed.
  std::vector<double> clipped_volumes;
  long triangles_before_decimation = 0;
  int slices_with_contours = 0;
  FitStats fit;                ///< marker2006: summed over slices
  PixelBox box;                ///< cropped working region
  /// Most per-slice fields held at once: slices in flight, fields kept for an
  /// empty neighbour, spline knots and tangents (bounded by the window unless
  /// the natural spline or an empty slice needs more; docs/decisions.md).
  long peak_resident_fields = 0;
  /// field3d: its field's solve (the run's report); unset for the column methods.
  std::optional<Field3dStats> field3d;

  /// A label partition's mesh while it waits in a scratch file
  /// (ReconstructOptions::scratch_dir); `mesh` is empty until it is loaded.
  std::shared_ptr<MeshSpill> spilled;
  /// ReconstructOptions::on_object wrote the mesh and it was freed: its
  /// counts stay here (vertex_count(), triangle_count()).
  bool mesh_freed = false;
  std::size_t freed_vertices = 0, freed_triangles = 0;

  [[nodiscard]] std::size_t vertex_count() const { return mesh_freed ? freed_vertices : mesh.vertices.size(); }
  [[nodiscard]] std::size_t triangle_count() const { return mesh_freed ? freed_triangles : mesh.triangles.size(); }
  /// After its mesh is written: the memory returned, its counts kept.
  void free_mesh() {
    if (!mesh_freed) freed_vertices = mesh.vertices.size(), freed_triangles = mesh.triangles.size();
    mesh_freed = true;
    mesh = TriMesh{};
  }
};

/// One slice's intermediate fields (marker2006), for --dump-stages.
struct SliceStageFields {
  std::uint32_t label = 0;
  int slice = 0;
  PixelBox box;                 ///< where the crop sits in the slice
  OrientedPoints points;        ///< contour points and outward normals (crop coordinates)
  Grid2f mpu;                   ///< MPU function f (positive inside)
  Grid2f distance;              ///< signed Euclidean distance (narrow band + extension)
  Grid2f filtered;              ///< after the distance-dependent filter
};

/// One object's cost, known after its contour stage and before any fit, for
/// a budget check (ReconstructOptions::on_estimate). Estimates, not bounds:
/// docs/decisions.md (work budget) has their measured accuracy.
struct WorkEstimate {
  std::uint32_t label = 0;
  PixelBox box;             ///< the crop of every field
  long slices = 0;          ///< input slices (the fields add 2 end caps)
  double planes = 0;        ///< z planes sampled for Marching Cubes
  double triangles = 0;     ///< Marching Cubes triangles before decimation
  double field_bytes = 0;   ///< per-slice fields, spline and fine rasters in flight
  double mesh_bytes = 0;    ///< the mesh before decimation and its checks
  double plane_bytes = 0;   ///< one sampled plane (float, padded crop), e.g. of --volume
  /// field3d (no crop, planes or per-slice fields; field_bytes its solve):
  /// the finest grid's nodes per axis ({0, 0, 0} for a column method) and the
  /// samples on its sections.
  std::array<int, 3> grid{};
  double samples = 0;
};

/// One z slab of a run cut into `count` (docs/decisions.md, "Z slabs"): the
/// Marching Cubes planes from cut `index` to cut `index + 1` (cut c: the last
/// plane at or below slice c * slices / count), meshed open at the cuts, from
/// knots computed with a halo; joined by weld_slabs() the slabs' meshes are
/// the one-piece mesh.
/// Most z slabs a run is cut into (a slab needs a plane of its own anyway).
inline constexpr std::size_t kMaxZSlabs = 1 << 16;

struct ZSlab {
  std::size_t index = 0;  ///< 0 .. count - 1, bottom up
  std::size_t count = 1;  ///< 1: the whole run
};

struct ReconstructOptions {
  /// Per object after its contour stage, before the fit; may throw to stop
  /// the run (e.g. over a memory budget).
  std::function<void(const WorkEstimate&)> on_estimate;
  std::vector<std::uint32_t> labels;  ///< labels input: only these (empty = all); an error with other inputs
  /// Per slice (marker2006), from worker threads.
  std::function<void(const SliceStageFields&)> on_slice_fields;
  /// Every sampled plane of each object's field (padded crop), e.g. for --volume.
  std::function<void(std::uint32_t label, const Grid2f& plane, double x0, double y0, double z, int plane_index, int plane_count)> on_plane;
  /// Heights (working z, pixels) at which each object's interpolated field is
  /// wanted whole, e.g. every voxel slice for a dense label map; those within
  /// the object's z range (cap slices included) reach on_sample.
  std::vector<double> sample_z;
  /// Each object's field over its crop box at every sample_z it reaches.
  std::function<void(std::uint32_t label, const Grid2f& field, const PixelBox& box, double z)> on_sample;
  /// The object's label (0: the only object, or the label scan shared by
  /// every label), stage name, items done, items total; from worker threads.
  std::function<void(std::uint32_t label, const std::string& stage, long done, long total)> progress;
  /// Every slice field computed over the whole crop box, not only where it
  /// can reach the mesh (the same mesh bit for bit; methods/columns/field_band.h).
  bool whole_fields = false;
  /// Each object asked for, once final (decimated), from worker threads,
  /// beside its mesh check (so `check` is not set yet): it writes the mesh and
  /// must not change it; the mesh is freed after (ObjectResult::free_mesh()).
  /// Called by the columns family (methods with a family of their own do not).
  std::function<void(ObjectResult&)> on_object;
  /// Each meshed object once final, from worker threads, beside its mesh
  /// check and on_object: it reads the mesh (kept unless on_object frees it)
  /// and may set fields the check and on_object do not touch (e.g. the RT
  /// ROIs' contour distances), so they are not left for the run's end.
  /// Called by the columns family.
  std::function<void(ObjectResult&)> on_final;
  /// Scratch files go in this folder ("": all held in memory): the slice
  /// fields computed early only for an empty slice's value wait there until
  /// their knot (column methods); with on_object, a label partition's meshes
  /// wait there while its labels stream, each read back for its decimation,
  /// check and on_object, one object per thread.
  std::string scratch_dir;
  /// Only this z slab (column methods with the columns z scheme; no
  /// decimation, stage fields, planes or samples).
  ZSlab z_slab;
};

struct ReconstructResult {
  std::vector<ObjectResult> objects;
  StageTimes times;
  std::vector<std::string> warnings;
};

}  // namespace isoloft
