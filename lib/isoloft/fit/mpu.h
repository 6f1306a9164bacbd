// @file fit/mpu.h
// @brief An implicit curve through oriented contour points: 2D MPU (paper 2.1).
// Multi-level Partition of Unity implicits (Ohtake et al., SIGGRAPH 2003).
// Sign convention: f > 0 inside (normals point outward), ~ signed distance in
// pixels near the data. MPU (section 2): a quadtree over the points and
// MpuParams::domain; per cell a support circle of alpha x diagonal grown by
// (1 + lambda) to N_min points, a local function (fit/mpu_local.h), subdivision
// while the max Taubin distance |Q| / |grad Q| of the support points exceeds
// tol (so tol bounds the fit to the points); f = sum w_i Q_i / sum w_i. Departures
// (docs/decisions.md: departures from MPU):
// - Fallback: if MPU's model misses tol or a sign check, the other, then a
//   corner or a min/max join over the connected pieces of data.
// - Sign checks at cell corners, centre and edge midpoints instead of
//   auxiliary values, and ring checks: every pixel centre 1.5-3 px from the
//   data must keep its side within the leaf's cell; a cell failing one is
//   subdivided.
// - Component rule: growth stops once every piece the circle touches is inside.
// - Support reduction: a grown support missing tol is refitted with N_min
//   halved down to n_floor; once the cell's own circle holds n points, that
//   circle is fitted before the cell is subdivided; children resume from the
//   parent's last n.
// - Weighted error (weighted_error): a support point's distance counts by the
//   leaf's relative weight there, fully within a tenth beyond the cell's corners.
// - Stall rule: a support-bound cell with radius > kSupportShrink x its
//   parent's is not subdivided (unless it touches > kMaxComponents pieces).
// - Domain: with domain_distance > 0 (the narrow band, paper 2.2) cells
//   farther from every point get no local function.
// - Below weight_floor() (beyond the root or the domain) f blends into the
//   nearest point's distance.
// @warning Leaves stopped by max_depth or by the stall rule exceed tol.
// @warning Far from the data a conic can cross zero spuriously; features
// thinner than 2 px are removed from masks before the fit (contour/fill.h).
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
  /// Not a parameter: where f will be evaluated (px); empty = the points' box.
  Eigen::AlignedBox2d domain;
  /// Not a parameter: > 0: f is needed only within this distance of a point
  /// (px; the narrow band); 0: the whole root square.
  double domain_distance = 0.0;
};

/// Deepest quadtree level accepted.
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

/// The fitted curve, immutable (evaluate from any thread); default: -kEmpty everywhere.
class MpuCurve {
 public:
  /// |f| of an empty curve (as kNoSurfaceDistance).
  static constexpr double kEmpty = 1.0e6;

  /// A quadtree leaf: local function and support circle.
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
    /// Grown, and no smaller n fits in the cell's own circle (stall rule).
    bool support_bound = false;
    bool sign_ok = true;  ///< fn agrees with every sign check of the cell
    int pieces = 0;       ///< connected pieces of data in the support; 0 if no multi-part model was tried
  };

  /// f(p), positive inside.
  [[nodiscard]] double value(const Vec2d& p) const;
  /// grad f(p) (at a corner's kink, one side's).
  [[nodiscard]] Vec2d gradient(const Vec2d& p) const;
  void value_and_gradient(const Vec2d& p, double& value, Vec2d& gradient) const;

  /// Normalised weights at p: (leaf, w), (-1, w) for the fallback. For tests.
  [[nodiscard]] std::vector<std::pair<int, double>> weights(const Vec2d& p) const;

  [[nodiscard]] const std::vector<Leaf>& leaves() const { return leaves_; }
  [[nodiscard]] Eigen::AlignedBox2d root_box() const;
  /// Leaf weight sum below which the fallback blends in.
  [[nodiscard]] double weight_floor() const { return w_floor_; }
  /// Signed distance to the nearest data point.
  [[nodiscard]] double fallback(const Vec2d& p) const;

 private:
  friend class MpuBuilder;
  friend Grid2f evaluate_on_grid(const MpuCurve&, int, int, double, double, double, const Grid2u8*);

  struct Node {
    Eigen::AlignedBox2d box;  ///< bounds of the support circles of the leaves below
    int first_child = -1;     ///< 4 consecutive nodes; -1 for a leaf
    int leaf = -1;            ///< index into leaves_ for a leaf
  };

  /// Sums of w_i Q_i, w_i and their gradients at p.
  void accumulate(const Vec2d& p, double& num, double& den, Vec2d* dnum, Vec2d* dden) const;
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

/// Fits the curve (paper 2.1), in parallel.
/// \throw InputError (no file name) for no points, a size mismatch, a
///        non-finite point or a normal not of unit length (+-1e-3);
///        ParamError for a parameter out of range or a non-finite domain.
MpuResult fit_mpu(const OrientedPoints& points, const MpuParams& params = {});

/// f at (x0 + i step, y0 + j step) as pixel (i, j), parallel over rows.
/// \param where if given (width x height): only its non-zero pixels are
///        evaluated, the others are -MpuCurve::kEmpty.
/// \throw ParamError if width or height < 0, step <= 0, or `where` has another size.
/// @warning An empty curve gives -MpuCurve::kEmpty everywhere.
Grid2f evaluate_on_grid(const MpuCurve& curve, int width, int height, double x0 = 0.0, double y0 = 0.0,
                        double step = 1.0, const Grid2u8* where = nullptr);

}  // namespace isoloft
