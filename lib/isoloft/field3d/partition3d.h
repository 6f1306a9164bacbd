// @file field3d/partition3d.h
// @brief Several labels drawn on the same sections as one partition of space
// (issue 35 item 3): no gaps, no point claimed twice, shared boundaries meshed
// once per side with the same vertices.
// Each label's field f_l comes from reconstruct_sections() on one grid for
// the labels whose grids overlap (a group: a common box, field3d/field3d.h
// Field3dParams::box). A point belongs to the label of the largest f_l, and
// to none where every f_l < 0; with F_l = max_{m != l} f_m, label l's surface
// is the zero set of
//   g_l = min(f_l - F_l, 2 R(f_l, F_l)),  R(a, b) = a + b + sqrt(a^2 + b^2)
// (R, Rvachev's union: positive iff a > 0 or b > 0). Where two labels meet
// both fields are about 0 (each label's drawn boundary runs along the shared
// face), R ~ sqrt(2) |f_l| >= |f_l - F_l| / 2, so g_l = f_l - F_l = -g_m:
// Marching Cubes puts their shared vertices at the same points (one
// interpolation, operands negated); away from the others R ~ 2 f_l keeps
// f_l's own zero set. g_l and g_m are never both positive at a grid node.
// (g_l = f_l - max(0, F_l) left a sheet between touching labels where both
// fields are <= 0: docs/decisions.md, touching labels.) Labels whose grids do
// not overlap are solved alone, exactly as reconstruct_sections() solves them.
// Units: world millimetres in and out.
// @warning A group's grid spans its labels' common box at Field3dParams::resolution
// cells along its longest side: labels that touch share the cells of their
// union's box, coarser than each alone.
// @warning Nested labels (one drawn inside another) are carved: the inner
// label's region leaves the outer's (a label map has one label per point).
#pragma once

#include <cstdint>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "isoloft/field3d/field3d.h"

namespace isoloft {

/// One label's surface in the partition.
struct Partition3dObject {
  std::uint32_t label = 0;
  TriMesh mesh;  ///< world mm, closed, counter-clockwise seen from outside
  MeshCheck check;
  std::vector<Field3dPlaneResidual> planes;  ///< one per section
  std::size_t group = 0;                     ///< index into Partition3dResult::groups
  std::vector<Field3dConflict> conflicts;    ///< its field's, as reconstruct_sections() finds them
  std::vector<std::string> warnings;         ///< one per conflict
  Field3dStats stats;                        ///< its field's solve; the planes those of `mesh`
};

struct Partition3dResult {
  std::vector<Partition3dObject> objects;           ///< in the order of the labels asked for
  std::vector<std::vector<std::uint32_t>> groups;   ///< labels solved on one grid (their grids overlap)
  double seconds = 0;                               ///< wall time of the whole call
};

/// The surfaces of `labels` (distinct, each drawn on some section) as one
/// partition of space. `pixel` > 0: the contours were traced from label
/// images whose finest pixel is `pixel` mm, and each group's grid and rows
/// are the pixel input's (field3d/image_sections.h pixel_rows(),
/// pixel_resolution() over the group's box) instead of params.resolution.
/// \throw ParamError, InputError as reconstruct_sections(); ParamError for
///        an empty or repeated label list, or params.box given (it is set per group).
Partition3dResult reconstruct_partition(const std::vector<Section>& sections, const std::vector<std::uint32_t>& labels,
                                        const Field3dParams& params = {}, double pixel = 0);

/// `label`'s work in the partition (estimate_sections() on its group's grid),
/// with solve_bytes the whole partition's peak: the largest group's largest
/// solve plus the fields and meshes of that group's labels, held together
/// until each label's surface is cut from them.
/// \throw as reconstruct_partition().
Field3dWork estimate_partition(const std::vector<Section>& sections, const std::vector<std::uint32_t>& labels,
                               std::uint32_t label, const Field3dParams& params = {}, double pixel = 0);

/// One input's partition shared by its jobs, one job per label (a CSL
/// file's, run/inputs.cpp): the first job that asks solves every label, each
/// job takes its own label's object. Thread-safe; the params of the first
/// call are used (every job of a run has the same).
class SharedPartition {
 public:
  explicit SharedPartition(std::vector<std::uint32_t> labels) : labels_(std::move(labels)) {}
  /// Every label of the partition, ascending as given.
  [[nodiscard]] const std::vector<std::uint32_t>& labels() const { return labels_; }
  /// Label `label`'s object (moved out: each label once); `seconds` the
  /// partition's wall time for the first taker, 0 for the others; `pixel`
  /// as reconstruct_partition()'s. `before(solves)`, under the lock before
  /// anything else (e.g. a budget check that throws): solves is true for
  /// the taker that solves the partition.
  /// \throw as reconstruct_partition() (every taker, the first error);
  ///        ParamError for a label not in the list or taken twice; what `before` throws.
  Partition3dObject take(const std::vector<Section>& sections, std::uint32_t label, const Field3dParams& params,
                         double pixel, double& seconds, const std::function<void(bool solves)>& before = {});

 private:
  std::vector<std::uint32_t> labels_;
  std::mutex mutex_;
  std::optional<Partition3dResult> result_;
  std::vector<bool> taken_;
};

namespace detail {
/// The params of one group's grid (indices into `labels`): its common box
/// when it has several labels, and for pixel input (`pixel` > 0) the pixel
/// rows (pixel_rows()) and pixel cells over that box (pixel_resolution()).
Field3dParams group_params(const std::vector<Section>& sections, const std::vector<std::uint32_t>& labels,
                           const std::vector<std::size_t>& group, const Field3dParams& params, double pixel);

/// The labels' groups: labels whose grid boxes (their contours' box with
/// Field3dParams::margin, as reconstruct_sections() builds it) overlap,
/// transitively; indices into `labels`, each group ascending, groups by
/// their first index.
std::vector<std::vector<std::size_t>> overlapping_labels(const std::vector<Section>& sections,
                                                         const std::vector<std::uint32_t>& labels, double margin);
}  // namespace detail

}  // namespace isoloft
