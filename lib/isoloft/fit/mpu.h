// Stage 2 (Marker, Braude, Museth, Breen 2006, paper 2.1): an implicit curve
// through the oriented contour points, by a 2D version of Multi-level
// Partition of Unity implicits (Y. Ohtake, A. Belyaev, M. Alexa, G. Turk,
// H.-P. Seidel, "Multi-level Partition of Unity Implicits", SIGGRAPH 2003;
// "MPU" below, section numbers are MPU's). f > 0 inside, f < 0 outside
// (normals point outward, so f decreases along them); near the data f is close
// to the signed distance in pixels.
//
// What is implemented, and how it maps to MPU:
// - Quadtree (MPU's octree). Root: the square around the points' bounding box
//   and MpuParams::domain. Every cell gets a support circle centred at the cell
//   centre c, radius R = alpha * (cell diagonal) (MPU 2: alpha = 0.75). If it
//   holds fewer than N_min points, R grows by R <- (1 + lambda) R (lambda =
//   0.1) until it does, so a cell far from all data still gets a local
//   function and every point of the root square is covered (a point of leaf
//   cell i has weight >= b(0.75 / alpha) > 0 from cell i). N_min is capped at
//   the number of points.
// - Local function (MPU 3), weights w(p) = b(3 |p - c| / (2 R)) on the support
//   points, n = their weighted mean normal. MPU's rule picks the model:
//   * a height function w = h(u), h quadratic, over the axis n through c,
//     Q = h(u) - w, weighted least squares (MPU's "bivariate quadratic
//     polynomial in local coordinates"; the common case) if every normal is
//     within 90 degrees of n and N <= 2 N_min;
//   * else a general conic a x^2 + b xy + c y^2 + d x + e y + f (MPU's "general
//     3D quadric") by weighted least squares on the points plus auxiliary
//     off-surface points p -/+ 1 px n with values +/- 1 px
//     (detail::kOffSurfaceDelta), taken as a central difference, which fixes
//     orientation and scale (grad Q . n = -1) without biasing the zero set;
//   * sharp features (MPU's "edge" in 3D is a corner in 2D): the normals are
//     split into 2 or 3 clusters (cut at the largest angular gap, optimal 1D
//     k-means; neighbouring means >= corner_angle apart), clusters split
//     further into connected parts (two parallel sides share a normal), one
//     piece per part; 2 pieces: min at a convex corner (each part lies behind
//     the other's mean normal), max at a concave one; 3 pieces (bar end,
//     step): the min/max combination with the least error.
// - Error and subdivision (MPU 2): the error of a local function is the
//   maximum over the support points of the Taubin distance |Q(p)| / |grad Q(p)|
//   (weighted, see below); cells are subdivided into 4 while it exceeds tol.
//   Cells are fitted eagerly, level by level (in parallel), not lazily during
//   evaluation as in MPU; the function is the same.
// - Blend (MPU 2): f(x) = sum_i w_i(x) Q_i(x) / sum_i w_i(x) over the leaves,
//   w_i(x) = b(3 |x - c_i| / (2 R_i)), b the quadratic B-spline; the
//   normalised weights are a partition of unity.
//
// Departures from MPU, each for a failure measured on digitised contours with
// N_min ~ 150 (a support is then an arc of >= 75 px, far longer than MPU's
// 15-point patches; measured failures: sign errors and zeros up to 70 px off):
// - Model fallback: if MPU's pick misses tol or a sign check, the other single
//   model is tried, then a corner (above) if the support holds one connected
//   piece of data, else one group per piece (its best of height function /
//   conic / corner; the kMaxComponents = 4 largest pieces) joined bottom-up,
//   each step by the min or max with the least error (min where each lies
//   inside the other: a hole in a region, a thin wall; max where neither
//   does: regions across a gap, an island in a hole). Pieces of data: points
//   linked closer than component_link x the median point spacing. The
//   candidate that passes the sign checks with the least error is kept. (A
//   parabola cannot follow an arc of 60+ degrees, which a conic fits exactly;
//   no single quadric fits both sides of a gap narrower than the support.)
// - Sign checks instead of MPU's auxiliary values: MPU constrains the quadric
//   at the cell corners and centre to d = mean (p_k - q) . n_k over the 6
//   nearest points. Those values grow linearly with the distance, a conic
//   quadratically, so with cell corners 50-100 px from the data they moved the
//   zero set by up to 20 px. Here the same points (plus the edge midpoints)
//   only check the sign of Q, taken from the nearest point p: (p - q) . n_p,
//   where q is >= 2 px from the data and within 60 degrees of n_p (not MPU's
//   6 nearest: in front of a wedge's tip both sides' tangents see q inside).
//   A second set, the ring checks, covers the data itself: every lattice
//   point (pixel centre) 1.5-3 px from its nearest point, its side by the same
//   rule; a leaf must have each one's side within its core (weight >= b(0.75
//   / alpha), the whole cell). They catch a curve that holds tol at every
//   point but strays beside them: a spike's two sides running on 3-4 px past
//   its tip, a wedge overshooting (measured on the frog labels: every pixel
//   the sign guard overruled was one of these). A cell whose best fit fails a
//   check is subdivided.
// - Component rule: support growth also stops once the circle holds a point
//   and every connected piece it touches lies wholly inside it, so an island
//   or hole with fewer than N_min points gets fits of its own.
// - Support reduction: a cell whose support had to grow and still misses tol
//   is refitted with N_min halved, down to n_floor, each support grown exactly
//   to its n-th nearest point (no lambda steps); the best is kept. Once the
//   cell's own circle holds n points, the cell is subdivided instead. Features
//   smaller than N_min points (petals, bar ends) are otherwise never resolved:
//   subdividing a support-bound cell gives children with the same support.
//   Once n is small enough for the cell's own circle, that circle (MPU's
//   support for this N_min) is fitted too before the cell is subdivided
//   (frog labels: 8,022 -> 5,845 leaves). Children start their reduction at
//   the N_min their parent ended with (its larger circle already failed every
//   larger one): on the frog labels this cut the fit time 3.4x for 3 % fewer
//   leaves. n_floor = 6 (a conic has 5
//   degrees of freedom; one point to spare): the 2 px bumps, bar ends and
//   strand tips of label boundaries need arcs that short (measured, leaves
//   over tol / largest error: frog labels n_floor 20: 25 % / 108 px, 12:
//   3.6 % / 3.3 px, 8: 0.29 % / 1.75 px, 6: 0.03 % / 1.50 px; AAL Putamen_L
//   from every 2nd slice 45 % / 2.8 px, 13 % / 7.0 px, 2.9 % / 2.2 px,
//   1.9 % / 1.1 px).
// - Stall rule: for the same reason a support-bound cell whose support radius
//   exceeds 0.8 of its parent's (detail::kSupportShrink) is not subdivided,
//   unless its support touches more than kMaxComponents pieces; MPU would
//   subdivide it down to max_depth without reducing the error.
// - Weighted error (weighted_error): a support point's Taubin distance counts
//   by min(1, w(p) / b(1.1 x 0.75 / alpha)), the leaf's weight there over the
//   weight it has a tenth beyond its own cell's corners
//   (detail::kFullErrorReach). Every point of the cell counts fully, as in
//   MPU; beyond, in the rim of a support grown to N_min points, a point
//   counts as much as the leaf weighs in the blend there. MPU's plain maximum
//   let rim points the leaf hardly weighs (down to 1e-12) decide: on the frog
//   labels 80 % of the leaves were over tol, mostly cells 20-150 px from any
//   data whose supports only reach the data with their rim, and subdividing
//   them only multiplied them (42,522 leaves; up to 746 covering one point).
// - Domain (domain_distance): with a narrow band to fill (paper 2.2: the MPU
//   values are used only in a band around the data), cells farther than
//   domain_distance from every point get no local function; f is then MPU's
//   within that distance, the fallback below beyond it.
// - Outside the root square, where the leaf weights fade out, f blends into a
//   fallback F(x) = s |x - p| with p the nearest data point and s the sign of
//   (p - x) . n_p (behind the nearest point's normal = inside):
//   f = (sum w_i Q_i + w0 F) / (sum w_i + w0), w0 = max(0, w_floor - sum w_i),
//   w_floor = b(0.75 / alpha) / 2: f is continuous, and w0 = 0 (pure MPU) in
//   the whole root square.
// With these, on digitised slices (tests and random blob slices with holes,
// islands, necks, border contact) no pixel farther than 3 px from the contour
// has the wrong sign and no zero lies farther than 1.2 px from a contour
// pixel (measured; the tests bound it by tol + 1 px).
//
// What tol bounds: the Taubin distance (the first-order Euclidean distance)
// from every input point in a leaf's cell (its core circle) to that leaf's
// local zero set, in pixels, and beyond it in the support that distance times
// the leaf's relative weight (weighted error). f at a data point is a convex
// combination of local functions, those of full weight all vanishing within
// tol of it, all with |grad| ~ 1 there, so the zero set of f passes within
// ~tol of every input point. It bounds the fit to the points, not to the
// unknown true curve (digitised contour pixels lie up to 1 px inside it, see
// the tests; mask edge points within 0.5 px of a digitised disk's edge,
// measured for radii 5-80 px, so tol = 0.75 is above that noise). Leaves can
// exceed tol only when stopped by max_depth or by the stall rule with n_floor
// points still too many (MpuResult reports them, Leaf::support_bound marks the
// latter). At tol = 1, circle, ellipse, annulus, two circles, square with
// hole fit with no leaf over tol (tests/fit/test_mpu.cpp).
//
// Thread safety: fit_mpu runs its levels in parallel (TBB); an MpuCurve is
// immutable and may be evaluated from any number of threads.
//
// Units: pixels of the working grid, pixel-centre convention (core/grid.h).
#pragma once

#include <Eigen/Geometry>
#include <cstddef>
#include <utility>
#include <vector>

#include "isoloft/contour/normals.h"
#include "isoloft/core/grid.h"
#include "isoloft/core/mesh.h"
#include "isoloft/core/params.h"
#include "isoloft/fit/mpu_local.h"
#include "isoloft/fit/point_grid.h"

namespace isoloft {

struct MpuParams {
  int n_min = 150;
  int n_floor = 6;
  double tol = 0.75;
  double alpha = 0.75;
  double lambda = 0.1;
  int max_depth = 10;
  double corner_angle = 25.8;
  double component_link = 2.0;
  bool weighted_error = true;
  /// Not a user parameter: the region the curve will be evaluated on, pixels
  /// (e.g. [-0.5, w - 0.5] x [-0.5, h - 0.5] for a w x h grid); the root
  /// square covers it and the points. Empty: the points' bounding box alone.
  Eigen::AlignedBox2d domain;
  /// Not a user parameter: > 0: the curve will be evaluated only within this
  /// distance of a point (the narrow band, paper 2.2); cells farther away get
  /// no local function (file comment, "Domain"). 0: the whole root square.
  double domain_distance = 0.0;
};

/// Deepest quadtree level accepted (2^-24 of the root cell).
inline constexpr int kMaxMpuDepth = 24;

template <>
inline const ParamTable<MpuParams>& params_table<MpuParams>() {
  static const ParamTable<MpuParams> t({
      field("n_min", &MpuParams::n_min, "points", "N_min: points per local fit (paper 2.1, Table 2; MPU 2)", at_least(1))
          .cli("--n-min"),
      field("n_floor", &MpuParams::n_floor, "points",
            "smallest N_min a support-bound cell falls back to when it misses tol (not in MPU)", at_least(1)),
      field("tol", &MpuParams::tol, "px",
            "error bound: largest Taubin distance of a leaf's support points from its local curve (paper 2.1; MPU 2)",
            above(0)).cli("--tol"),
      field("alpha", &MpuParams::alpha, "", "support radius over cell diagonal (MPU 2); > 0.5 so a cell lies in its support",
            above(0.5)),
      field("lambda", &MpuParams::lambda, "", "relative growth step of a support short of N_min points (MPU 2)", above(0)),
      field("max_depth", &MpuParams::max_depth, "levels", "deepest quadtree level, root = 0 (a safety net; not in MPU)",
            between(0, kMaxMpuDepth)),
      field("corner_angle", &MpuParams::corner_angle, "deg",
            "least angle between neighbouring normal clusters of a corner fit (MPU 3, sharp features)",
            open_between(0, 180)),
      field("component_link", &MpuParams::component_link, "spacings",
            "points closer than this many median point spacings form one connected piece", at_least(0)),
      field("weighted_error", &MpuParams::weighted_error, "",
            "a support point's error counts fully within (a tenth beyond) the leaf's cell, beyond it by the leaf's "
            "relative weight there (not in MPU; false = every support point fully)"),
  });
  return t;
}

/// The fitted curve: an immutable function, safe to evaluate from many threads.
/// A default-constructed one holds no data and is -kEmpty (outside) everywhere.
class MpuCurve {
 public:
  /// Magnitude of the value of an empty curve (as field/edt.h's kNoSurfaceDistance).
  static constexpr double kEmpty = 1.0e6;

  /// One leaf of the quadtree: its local function and support circle.
  struct Leaf {
    detail::LocalFn fn;
    Vec2d centre{0.0, 0.0};
    double radius = 0.0;     ///< support radius R (after growth)
    double half_size = 0.0;  ///< half the cell side
    double error = 0.0;      ///< Taubin error over the support points
    int depth = 0;
    int support = 0;     ///< points in the support circle
    int n_target = 0;    ///< N_min used (n_min, or less after support reduction)
    int n_last = 0;      ///< smallest N_min the support reduction tried (a child starts from it)
    bool grown = false;  ///< the support radius grew beyond alpha x diagonal
    /// Grown, and no smaller n fitted inside the cell's own circle: the fit is
    /// bound by its support, not by the cell size (stall rule).
    bool support_bound = false;
    bool sign_ok = true;  ///< fn agrees with every sign check of the cell
    int pieces = 0;       ///< connected pieces of data in the support; 0 if no multi-part model was tried
  };

  /// f(p), positive inside, ~ signed distance in pixels near the curve.
  [[nodiscard]] double value(const Vec2d& p) const;
  /// grad f(p) (analytic; at the kinks of a corner leaf, one side's).
  [[nodiscard]] Vec2d gradient(const Vec2d& p) const;
  void value_and_gradient(const Vec2d& p, double& value, Vec2d& gradient) const;

  /// The normalised blending weights at p: (leaf index, weight), plus
  /// (-1, weight) for the fallback when it takes part. They sum to 1.
  /// O(leaves), for tests and inspection.
  [[nodiscard]] std::vector<std::pair<int, double>> weights(const Vec2d& p) const;

  [[nodiscard]] const std::vector<Leaf>& leaves() const { return leaves_; }
  /// Root square of the quadtree.
  [[nodiscard]] Eigen::AlignedBox2d root_box() const;
  /// Sum of leaf weights below which the fallback blends in.
  [[nodiscard]] double weight_floor() const { return w_floor_; }
  /// Fallback F(p) (file comment): signed distance to the nearest data point.
  [[nodiscard]] double fallback(const Vec2d& p) const;

 private:
  friend class MpuBuilder;
  friend Grid2f evaluate_on_grid(const MpuCurve&, int, int, double, double, double, const Grid2u8*);

  struct Node {
    Eigen::AlignedBox2d box;  ///< bounds of the support circles of the leaves below
    int first_child = -1;     ///< 4 consecutive nodes; -1 for a leaf
    int leaf = -1;            ///< index into leaves_ for a leaf
  };

  /// Sums of w_i Q_i, w_i and their gradients over the leaves covering p.
  void accumulate(const Vec2d& p, double& num, double& den, Vec2d* dnum, Vec2d* dden) const;
  /// Nearest data point and its outward normal.
  void fallback_eval(const Vec2d& p, double& value, Vec2d& grad) const;

  std::vector<Node> nodes_;
  std::vector<Leaf> leaves_;
  Vec2d root_centre_{0.0, 0.0};
  double root_half_ = 0.0;
  double w_floor_ = 0.0;
  detail::PointGrid grid_;  ///< the data points (fallback)
  std::vector<Vec2d> normals_;
};

struct MpuResult {
  MpuCurve curve;
  int cells = 0;  ///< quadtree cells fitted (internal + leaves)
  int cells_outside_domain = 0;  ///< cells beyond MpuParams::domain_distance: no local function
  int leaves = 0;
  int max_depth_reached = 0;
  double max_local_error = 0.0;          ///< max leaf error (Taubin distance, px)
  int leaves_over_tol = 0;               ///< leaves with error > tol: support-bound (stall rule) or at max_depth
  int leaves_over_tol_at_max_depth = 0;  ///< of those, the ones stopped by max_depth
  int quadric_leaves = 0, height_leaves = 0, corner_leaves = 0, component_leaves = 0;
  int grown_leaves = 0;         ///< leaves whose support radius had to grow
  int sign_check_failures = 0;  ///< leaves whose best model failed a sign check
  int components = 0;           ///< connected pieces of the point set (component rule)
};

/// Fits the 2D MPU curve to oriented points (paper 2.1; algorithm in the file comment).
/// \pre points.size() == normals.size() >= 1; points finite; normals unit length.
/// \throw InputError (empty file name; the caller prefixes the slice) if there
///        are no points, the sizes differ, or a point or normal is not finite
///        or a normal is not of unit length (+-1e-3).
/// \throw ParamError if n_min < 1, n_floor < 1, tol <= 0, alpha <= 0.5, lambda <= 0,
///        max_depth outside [0, 24], corner_angle outside (0, 180),
///        component_link < 0, or a parameter is not finite.
MpuResult fit_mpu(const OrientedPoints& points, const MpuParams& params = {});

/// f at the points (x0 + i step, y0 + j step), i < width, j < height: pixel
/// (i, j) of the result. Parallel over rows (TBB); equal to value() up to
/// rounding (the same sums in another order).
/// \param where if given (width x height): only pixels where it is non-zero
///        are evaluated, the others are -MpuCurve::kEmpty.
/// \throw ParamError if width or height < 0, step <= 0, or `where` has
///        another size.
Grid2f evaluate_on_grid(const MpuCurve& curve, int width, int height, double x0 = 0.0, double y0 = 0.0,
                        double step = 1.0, const Grid2u8* where = nullptr);

}  // namespace isoloft
