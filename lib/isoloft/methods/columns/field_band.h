// @file methods/columns/field_band.h
// @brief Where a slice's field can reach the mesh: the pixels whose exact
// value the z splines and Marching Cubes read (docs/decisions.md, "Fields
// only where they reach the mesh").
//
// A slice field's sign is known from its masks alone beyond `unknown_within`
// of a contour pixel: the traced mask boundary keeps every pixel centre on its
// mask side (contour/mask_curve.h, clamped_smoothed_mask), drawn polygons sign
// by the even-odd rule, which is the masks' inside but on contour pixels. Over
// a knot interval whose two knots keep one known side at a pixel, a monotone,
// extremum-preserving or linear spline keeps that side (interp/spline.h), so
// no Marching Cubes edge at that pixel is crossed there and its value is
// never read. A knot's exact value is needed at a pixel (`needed`) if the
// pixel or a neighbour lies in a knot interval whose sides are unknown or
// differ, among the intervals whose splines read the knot (the tangent
// reach); the distance filter reads the stencils of `needed` pixels
// (`required`, where the extension stops). Elsewhere any value of the known
// side gives the same mesh, bit for bit.
//
// A slice's field is also read through the knots made from it: the end caps
// (from the end slice and, round and slab, the trend of the slice before it)
// and the closing of an empty neighbour (secant: of the isolated empty slice
// beyond it too). Slab and flat caps and closings read it pixel by pixel, so
// its band is the union of the bands of the slices whose knots read it
// (`spread` slices at most on each side; a cap's knot reads no interval its
// end slice's does not). Dome and round caps read its maximum: end slices
// and slices next to an empty one are then `full` (the whole field). Empty
// slices and the caps are outside everywhere (cap_extent <= 1). Inside pixels
// on the ring of the crop box count as unknown: the mesher's outside pad
// meets them.
// @warning Only for the paths whose sign is the masks' (traced masks, drawn
// polygons); field_band_setup() says which runs qualify.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <vector>

#include "isoloft/core/grid.h"
#include "isoloft/objects/slice_fields.h"

namespace isoloft::detail {

/// Per pixel of `box`: +1 inside, -1 outside, 0 within `unknown_within`
/// (Chebyshev, px) of a contour pixel, and 0 for an inside pixel on the box's
/// ring; all -1 for an empty slice.
Grid2<std::int8_t> known_sides(const PackedMasks& m, const PixelBox& box, int unknown_within);

/// 1 where a pixel within r (Chebyshev) of the pixel is 1.
Grid2u8 dilate_square(const Grid2u8& g, int r);

class PartitionCrossings;

/// The bands of an object's slices, computed a window at a time from the
/// packed masks (which must still be there when prepare() covers them).
class FieldBand {
 public:
  struct Setup {
    int unknown_within = 0;  ///< px: see known_sides()
    std::size_t reach = 0;   ///< the spline's tangent reach (interp/z_stream.h)
    int filter_reach = 0;    ///< px: the filter's stencil radius (0 = no filter)
    bool trend_caps = false;  ///< the caps read the second (and second to last) slice too
    bool whole_ends = false;  ///< caps and closings read their slice's maximum (dome, round)
    std::size_t spread = 1;   ///< slices: an empty slice's knot reads non-empty slices this far
    /// A label partition's: its labels' bands (PartitionCrossings), this label's index there.
    std::shared_ptr<PartitionCrossings> partition;
    std::size_t label = 0;
  };
  FieldBand(const std::vector<PackedMasks>& masks, const PixelBox& box, const Setup& setup);

  /// Makes band() answer for slices [k0, k1): the crossings of the knot
  /// intervals their splines read, up to k1 + reach, computed (in parallel),
  /// those below k0 - reach dropped. Calls in increasing order.
  void prepare(std::size_t k0, std::size_t k1);
  /// Slice k's band; nullopt: the whole field (a full slice). Thread-safe
  /// after prepare() for k.
  [[nodiscard]] std::optional<SliceBand> band(std::size_t k) const;

 private:
  const std::vector<PackedMasks>& masks_;
  PixelBox box_;
  Setup setup_;
  std::vector<char> full_;
  // Per slice: the slices [first, last] whose knots read its field (its own,
  // a cap's end slice, an empty neighbour).
  std::vector<std::pair<std::size_t, std::size_t>> readers_;
  // Per knot interval j (knots j, j + 1; knot 0 the cap below): 1 where its
  // sides are unknown or differ. Intervals [first_, first_ + size).
  std::deque<Grid2u8> crossing_;
  std::size_t first_ = 0;
};

/// The bands of a label partition's labels (docs/decisions.md, "The field
/// band in a label partition"). Where at a pixel every label's side
/// (known_sides over its box; outside beyond it) is known and the same at both
/// knots of an interval, each label's spline keeps that side; the labels'
/// masks are disjoint, so at most one is inside, and the union's knot (the
/// highest label knot plus a healing >= 0 that is 0 off the labels' pixels)
/// has its side: the competition's winner (partition/partition.h) is that
/// label, or the background, whatever the values. Two 8-adjacent pixels of
/// known sides have one winner (else a contour pixel lies within 1 px of
/// them), and a pixel's winner is the same on both sides of a knot. So every
/// Marching Cubes edge whose partition field changes sign has an end within
/// 1 px of an interval where some label's side is unknown or changes, and
/// there any label whose box holds the pixel may be the winner or the
/// runner-up the fields are compared against: every label's field is exact
/// there, not only the label whose contour it is. Each slice's band is made
/// once for all labels (thread-safe) and cropped to each label's box.
class PartitionCrossings {
 public:
  /// masks[l], boxes[l]: label l's (copies: the streams drop theirs); ubox
  /// the union's box, which holds every label's.
  PartitionCrossings(std::vector<std::vector<PackedMasks>> masks, std::vector<PixelBox> boxes, const PixelBox& ubox,
                     const FieldBand::Setup& setup);
  /// Label `label` will ask for slices [k0, k1): their bands computed (the
  /// intervals their splines read: FieldBand::prepare), those no label reads
  /// any more dropped.
  void prepare(std::size_t label, std::size_t k0, std::size_t k1);
  /// The union of slices [first, last]'s bands over `box` (within the
  /// union's), after prepare() for a slice within `spread` of them.
  [[nodiscard]] SliceBand band(std::size_t first, std::size_t last, const PixelBox& box) const;

 private:
  // Slice k over the union's box: l + 1 inside label l, -1 in none, 0 where
  // some label's side is unknown (known_sides over its box). An interval
  // crosses where either knot is 0 or the two differ: where some label's
  // crosses.
  [[nodiscard]] Grid2<std::int32_t> slice_sides(std::size_t k) const;

  std::vector<std::vector<PackedMasks>> masks_;
  std::vector<PixelBox> boxes_;
  PixelBox ubox_;
  FieldBand::Setup setup_;
  std::vector<std::size_t> asked_;  // per label: the k0 of its last prepare()
  mutable std::mutex m_;
  std::deque<Grid2u8> crossing_;  // over the union's box, intervals [first_, first_ + size)
  std::size_t first_ = 0;
  std::deque<SliceBand> bands_;  // over the union's box, slices [first_band_, first_band_ + size)
  std::size_t first_band_ = 0;
};

/// The band's setup for an object, or nullopt where a band could change the
/// mesh or is not derived: a method without curves, a slice path whose sign
/// is not the masks' (the MPU fit), a z scheme other than columns, mc.iso not
/// 0, a spline that can leave its knots' side (Catmull-Rom, natural), an
/// empty slice with no non-empty neighbour under isolated_empty lowest or
/// neighbours (it reads fields' lowest values) or empty slices with
/// cap_extent > 1 (their side is then not known).
std::optional<FieldBand::Setup> field_band_setup(const ReconstructParams& params, InputKind kind,
                                                 const std::vector<PackedMasks>& masks);

}  // namespace isoloft::detail
