// @file mesh/plane_cut.h
// @brief Where a plane z = const cuts a closed mesh: closed polygons, as an
// RT Structure Set holds a surface (io/rtstruct.h, write_rtstruct).
// A vertex exactly on the plane counts as above it (symbolic perturbation),
// so a plane through vertices, as Marching Cubes puts them on its sampled
// planes, still gives closed simple loops: the in-plane edges of the
// triangles below it. Also the loops' resampling to a point spacing (the
// density contours were drawn at) and the measures that compare loops.
#pragma once

#include <vector>

#include "isoloft/core/mesh.h"

namespace isoloft {

/// The loops (x, y) where the plane z = `z` cuts `mesh`, each closed (the
/// last point joins the first), counter-clockwise seen from +z around the
/// inside for a mesh oriented counter-clockwise seen from outside (holes
/// clockwise). Consecutive equal points are merged; loops of fewer than 3
/// points dropped.
/// @warning A mesh with boundary or non-manifold edges may give open chains:
/// they are dropped.
std::vector<std::vector<Vec2d>> cut_mesh(const TriMesh& mesh, double z);

/// A closed loop resampled along its length, and how far it departs from the
/// loop it replaces.
struct ResampledLoop {
  std::vector<Vec2d> points;
  /// Distance of each vertex of the input loop from the chord of `points`
  /// that spans it (same length along the loop): the resampling's departure
  /// from the exact polyline, its largest and mean.
  double max_deviation = 0, mean_deviation = 0;
};

/// Share of a loop's area its resampling may gain or lose: resample_loop()
/// adds points until the resampled loop's area is this close. At the drawn
/// step (about 1.7 mm on the shared RT set) an island of 2-4 mm^2 came back
/// as 3 or 4 chords that kept 37-45 % of it; 2 % is well under the round
/// trip's 25 % area target, and the whole loops of a drawn density already
/// meet it (their chords' sagitta is a tiny share of their area).
inline constexpr double kResampleAreaShare = 0.02;
/// Most points per vertex of the loop that resample_loop() adds for the area:
/// at equal steps a loop's corners are cut by at most a step, and with 8
/// steps per edge of a convex polygon the chords lose at most about 1/64 of
/// each corner's triangle; the cap only bounds the search.
inline constexpr std::size_t kResampleMostPerVertex = 8;

/// `loop` (closed, the last point joining the first) with m points at equal
/// steps of its length, starting at its first vertex: the least m from
/// max(3, round(length / spacing)) on whose loop keeps the area within
/// kResampleAreaShare (at most kResampleMostPerVertex times the loop's
/// count, unless the spacing asks for more). A loop of fewer than 3 points,
/// or a spacing <= 0, comes back as given (deviation 0).
/// @warning A chord cuts corners: the deviation grows as step^2 / (8 radius)
/// on a curve and up to about half a step at a sharp corner.
ResampledLoop resample_loop(const std::vector<Vec2d>& loop, double spacing);

/// Volume of the part of the closed `mesh` above the plane z = `z` (the
/// mesh clipped there and closed by its section), signed as the mesh's
/// volume (positive for one oriented counter-clockwise seen from outside).
/// With the origin on the plane the closing section adds nothing, so it is
/// the clipped triangles' tetrahedra only: O(triangles).
/// @warning A mesh with boundary edges gives a volume that depends on where
/// the origin is (no closed volume exists).
double volume_above(const TriMesh& mesh, double z);
/// volume_above() at each of `zs` in one pass over the triangles: each the
/// value volume_above(mesh, zs[i]) gives, bit for bit (the same sums in the
/// same order).
std::vector<double> volumes_above(const TriMesh& mesh, const std::vector<double>& zs);

/// Mean distance between consecutive points of closed loops, over all of
/// them (total length / total points); 0 if they have no points.
double mean_point_spacing(const std::vector<std::vector<Vec2d>>& loops);

/// Signed area of a closed loop (positive counter-clockwise).
double loop_area(const std::vector<Vec2d>& loop);

/// Distance from `p` to the closed polyline `loop` (its edges, the last
/// joining the first); infinity for an empty loop.
double distance_to_loop(const Vec2d& p, const std::vector<Vec2d>& loop);

}  // namespace isoloft
