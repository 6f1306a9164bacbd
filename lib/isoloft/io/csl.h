// @file io/csl.h
// @brief The CSL cross-section format (OReX, Zou et al., Huang et al.):
// planes at any angle, each with closed contours that carry a label and may
// be holes. One Section per plane, contours in in-plane millimetres.
//
// The format (whitespace-separated, one record per line, blank lines ignored):
//   CSLC                              magic
//   P L                               plane count, label count (>= 2: 0 is outside)
//   i V C A B C D                     plane i (1..P in order): V vertices, C components,
//                                     the plane A x + B y + C z + D = 0
//   x y z                             V vertex lines (0-based indices below)
//   N label j0 ... j(N-1)             C component lines: N vertex indices, closed;
//   NhK label j0 ... j(N-1)           a hole in component K (0-based, of this plane)
// Pose of plane i: normal n = (A, B, C) / |(A, B, C)|, origin the plane's point
// nearest the world origin (-D n / |(A, B, C)|), u the world axis least aligned
// with n made orthogonal to it, v = n x u (u x v = n; an axial plane gets u = x, v = y).
//
// @warning A plane with no vertices and no components is valid: all of it is
// outside every object (docs/decisions.md, "CSL reader"). A plane with vertices
// but no component is refused (the component count lies).
// @warning A hole's object is its parent's label. Its written label must be the
// parent's or L itself: OReX's slicer writes 2 for every hole of a 2-label
// file (balloondog, hand, Elephant, lamp004, Horsers).
// @warning The contours are not reoriented: inside is by even-odd nesting per
// label (core/section.h), whatever order the file lists the vertices in.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "isoloft/core/section.h"

namespace isoloft {

/// What read_csl() refuses beyond the format's counts.
struct CslParams {
  /// Refuse a contour that crosses or touches itself. lamp004_fixed.csl (OReX)
  /// has 4 such contours (folds of 1e-5..2e-3 units, extent 2.03) and is
  /// refused by default; false passes them through as drawn.
  bool refuse_self_intersections = true;
};

/// Vertices may leave their plane by this share of the file's extent (the
/// diagonal of all vertices' bounding box). Real files (22 in OReX's Data/)
/// stay within 4.9e-5 (Horsers.csl, its D given to 2 decimals) and the rest
/// within 1.4e-10; 1e-4 is a tenth of the 0.1 % of the diagonal that a
/// reconstruction's section is held to on its input planes (issue 35), so the
/// projection onto the plane costs at most a tenth of that budget.
inline constexpr double kCslOffPlaneTolerance = 1e-4;

/// A read CSL file.
struct CslFile {
  std::vector<Section> sections;  ///< one per plane, in file order
  std::uint32_t label_count = 0;  ///< declared label count, the outside label 0 included
};

/// Parses CSL text; `name` names it in errors and in each Section::source
/// ("name, plane 3").
/// \throw InputError(name, "plane i (line n): problem") for a wrong magic, a bad
///        number, a count that lies (vertex or component counts against what
///        follows, a plane index out of order, a truncated file, trailing
///        text), a zero or non-finite normal, a vertex off its plane by more
///        than kCslOffPlaneTolerance of the extent, a vertex index out of
///        range, a component of fewer than 3 vertices, a label 0 or >= L, a
///        hole whose parent is missing or a hole, a self-intersecting contour.
CslFile parse_csl(std::string_view text, const std::string& name, const CslParams& params = {});

/// Reads `path` (any size; mapped, not copied) as parse_csl with name = path.
/// \throw InputError(path, ...) as parse_csl, or if the file cannot be read.
CslFile read_csl(const std::string& path, const CslParams& params = {});

namespace detail {

/// The first pair of edges (i, j), i < j, of closed polyline `p` (edge e runs
/// from p[e] to p[e + 1 mod n]) that cross, touch or overlap: neighbours only
/// by folding back along one line. nullopt for a simple polygon; exact for the
/// double coordinates given (no tolerance). Sweep over x: about n log n for
/// drawn contours, n^2 at worst.
std::optional<std::pair<std::size_t, std::size_t>> first_self_contact(const std::vector<Vec2d>& p);

}  // namespace detail

}  // namespace isoloft
