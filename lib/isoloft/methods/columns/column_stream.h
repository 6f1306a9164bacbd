// @file methods/columns/column_stream.h
// @brief The column streaming engine of reconstruct() (paper 2.1-2.5 but
// decimation): an object's slice fields computed a window at a time in
// parallel (the method's MethodSpec::slice_field), the knot feed (end caps,
// empty slices closed), the z scheme's plane source, meshed plane by plane;
// only the packed masks are kept for every slice. Internals of
// reconstruct(), in detail.
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <optional>
#include <vector>

#include "isoloft/interp/z_stream.h"
#include "isoloft/mesh/stream_mesher.h"
#include "isoloft/methods/columns/field_band.h"
#include "isoloft/methods/params.h"
#include "isoloft/objects/objects.h"

namespace isoloft::detail {

/// The knot heights: the slices' z and the end caps' (add_end_caps; a cap of
/// an empty field is empty).
std::vector<double> knot_z(const Run& run);

/// A z slab's share of an object's stream (ReconstructOptions::z_slab).
struct SlabRange {
  std::size_t first_knot = 0;   ///< the stream's first knot: a halo of tangent_reach + 2 below the slab's first plane
  std::size_t first_slice = 0;  ///< the first slice whose field is computed (knots read their neighbours)
  std::size_t plane_begin = 0, plane_end = 0;  ///< the slab's planes of mesh_planes(knots), [begin, end)
};

/// The slab of `run` over the object's knots (knot_z) and planes; `empty`:
/// its empty slices (an isolated one takes the lowest value of every field,
/// so the fields are computed from the first slice). Without a slab: all.
/// \throw ParamError if the slab is not one of its count, two cuts fall on
///        one plane, or the z scheme is not the columns with a finite reach.
SlabRange slab_range(const Run& run, const std::vector<double>& knots, const std::vector<double>& planes,
                     const std::vector<char>& empty);

/// One object's cost from its packed masks, before any fit (the budget
/// check; docs/decisions.md, work budget); `window`: its slices computed at
/// once (0: slice_window()).
WorkEstimate estimate_work(const Run& run, const std::vector<PackedMasks>& masks, const ObjectResult& obj,
                           std::size_t window = 0);

/// One object's interpolated field, streamed (paper 2.1-2.4): the slice fields
/// computed a window at a time, the knot feed, the z scheme's plane source;
/// only the packed masks are kept for every slice.
class ObjectStream {
 public:
  /// Each knot the stream pulls, with its index, goes to `tap` too (if set).
  using KnotTap = std::function<void(std::size_t, const Grid2f&)>;

  /// band: the fields are exact only where they reach the mesh (methods/columns/field_band.h);
  /// window: slices computed at once (0: slice_window(); a partition's labels: partition_slice_window());
  /// z_block: intervals per z block of the columns scheme (ZSchemeInput::block; 0: its default).
  /// \throw InputError if the knots span less than one plane step.
  ObjectStream(const Run& run, ObjectResult& obj, std::vector<PackedMasks> masks, KnotTap tap = {},
               const std::optional<FieldBand::Setup>& band = std::nullopt, std::size_t window = 0,
               std::size_t z_block = 0);
  ~ObjectStream();
  ObjectStream(const ObjectStream&) = delete;
  ObjectStream& operator=(const ObjectStream&) = delete;

  [[nodiscard]] PlaneSource& field();
  [[nodiscard]] const std::vector<double>& knots() const;
  [[nodiscard]] std::vector<double> planes() const;

  /// The object's mesh and the stream's statistics and times; `interp_seconds`
  /// evaluating planes and samples.
  void finish(StreamMeshResult r, double interp_seconds);

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

/// The mesher's options for an object: the pad outside the end caps' value,
/// --volume planes, progress.
StreamMeshOptions mesh_options(const Run& run, const ObjectResult& obj);

/// Stages (paper 2.1-2.5 but decimation) of one object, its mesh into obj.
/// The fields banded (methods/columns/field_band.h) unless a hook sees them or the
/// options ask for whole fields. An empty mesh is made again with whole
/// fields: its reason quotes the fields' maximum, which a band does not keep.
void stream_stages(const Run& run, std::vector<PackedMasks> masks, ObjectResult& obj);

}  // namespace isoloft::detail
