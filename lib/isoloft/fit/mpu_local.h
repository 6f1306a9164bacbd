// @file fit/mpu_local.h
// @brief The local functions of the 2D MPU fit (internals, for the tests).
// MPU section 3 in 2D (height function, conic, sharp feature) and min/max joins
// over pieces of data. Sign convention: positive inside; Q in pixels.
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include "isoloft/core/mesh.h"

namespace isoloft::detail {

/// MPU's quadratic B-spline; a ball (c, R) weighs b(3 |x - c| / (2 R)).
double bspline2(double t);
double bspline2_derivative(double t);

/// Q = h(u) - w, h quadratic in u = t . (x - o), w = n . (x - o).
struct HeightFn {
  Vec2d o{0.0, 0.0}, n{0.0, 1.0}, t{-1.0, 0.0};
  double scale = 1.0;
  double a = 0.0, b = 0.0, c = 0.0;
  void eval(const Vec2d& x, double& value, Vec2d& grad) const;
};

struct CurvePiece {
  bool conic = false;
  HeightFn h;  ///< when !conic
  /// Conic: Q = S q(s), q quadratic in s = (x - centre) / S.
  Vec2d centre{0.0, 0.0};
  double scale = 1.0;
  std::array<double, 6> q{};
  void eval(const Vec2d& x, double& value, Vec2d& grad) const;
};

/// Up to three pieces joined by min/max: a smooth piece, a corner, a bar end or a step.
struct Group {
  enum class Op : std::uint8_t {
    Min,       ///< inside all pieces (convex corners)
    Max,       ///< inside any piece (concave corners)
    MaxOfMin,  ///< max(piece[lone], min(the other two))
    MinOfMax,  ///< min(piece[lone], max(the other two))
  };
  std::array<CurvePiece, 3> piece{};
  int count = 1;  ///< pieces used (1 to 3)
  Op op = Op::Min;
  int lone = 0;  ///< the piece outside the inner min / max (three pieces, mixed ops)
  void eval(const Vec2d& x, double& value, Vec2d& grad) const;
};

/// Most connected pieces of data one local function joins.
inline constexpr int kMaxComponents = 4;

/// One local function Q_i: a group, or a min/max join of a group per piece.
struct LocalFn {
  enum class Kind : std::uint8_t {
    Quadric,     ///< MPU "general 3D quadric" in 2D: one conic
    Height,      ///< MPU "bivariate quadratic polynomial": one height function
    Corner,      ///< MPU "sharp feature" in 2D: pieces split by normals, by min/max
    Components,  ///< one group per connected piece of data, joined by min/max
  };
  struct Join {
    bool use_min = true;
    std::int8_t a = 0, b = 0;
  };
  Kind kind = Kind::Height;
  std::array<Group, kMaxComponents> group{};
  int groups = 1;
  std::array<Join, kMaxComponents - 1> join{};
  int joins = 0;
  void eval(const Vec2d& x, double& value, Vec2d& grad) const;
  [[nodiscard]] double value(const Vec2d& x) const {
    double v;
    Vec2d g;
    eval(x, v, g);
    return v;
  }
};

/// Weighted least-squares height function over `normal` (unit, outward).
HeightFn fit_height(const std::vector<Vec2d>& points, const std::vector<int>& idx, const std::vector<double>& w,
                    const Vec2d& o, const Vec2d& normal, double scale);

/// A sign check at q: d = mean (p_k - q) . n_k over its 6 nearest points (> 0 inside).
struct AuxPoint {
  Vec2d q;
  double d;
};

/// Aux points nearer than this many pixels to a data point are not used as
/// sign checks: that near digitised data their side is noise.
inline constexpr double kSignCheckMargin = 2.0;

/// Weighted error: a support point counts fully up to this multiple of the
/// cell's centre-to-corner distance (weight argument t), beyond by the leaf's
/// relative weight (docs/decisions.md: weighted error).
inline constexpr double kFullErrorReach = 1.1;

/// Ring checks: pixel centres whose nearest point lies kRingNear-kRingFar px
/// away (near: 2 tol, where a curve within its bound has the data's side; far:
/// the band a stray curve piece would cross on its way to the sign guard's pixels).
inline constexpr double kRingNear = 1.5, kRingFar = 3.0;
/// A sign check takes its side from its nearest point only within this angle
/// of that point's normal, rad (allows for 2 px point spacing and noisy normals).
inline constexpr double kSideAngle = M_PI / 3.0;

/// A grown cell is not subdivided if its support radius exceeds this fraction
/// of its parent's (an ungrown child has half its parent's radius): the
/// children would hold about the same points, so no error could drop.
inline constexpr double kSupportShrink = 0.8;

/// Offset of a conic's off-surface pairs p -/+ delta n, px.
inline constexpr double kOffSurfaceDelta = 1.0;

/// Conic minimising sum w_k [Q(p_k)^2 + ((Q(p_k - delta n_k) - Q(p_k + delta n_k)) / 2 - delta)^2]
/// (the pairs fix orientation and scale: grad Q . n = -1).
CurvePiece fit_conic(const std::vector<Vec2d>& points, const std::vector<Vec2d>& normals, const std::vector<int>& idx,
                const std::vector<double>& w, const Vec2d& centre, double scale);

/// Max over idx of |Q(p)| / |grad Q(p)|.
double taubin_error(const LocalFn& fn, const std::vector<Vec2d>& points, const std::vector<int>& idx);

/// Normals of idx in k (2 or 3) clusters (cut at the largest gap, 1D k-means).
/// \return false if a cluster has < min_size points or neighbours' means are
///         closer than min_angle (rad).
bool split_normals(const std::vector<Vec2d>& normals, const std::vector<int>& idx, int k, double min_angle,
                   int min_size, std::vector<std::vector<int>>& parts);

/// The normals of points idx by angle, cut open at their largest gap (the
/// first step of split_normals, shared by its k = 2 and k = 3 splits).
struct NormalAngles {
  std::vector<std::pair<double, int>> order;  ///< (unrolled angle, point index), increasing
  std::vector<double> pre, pre2;              ///< prefix sums of the angles and of their squares
};
NormalAngles normal_angles(const std::vector<Vec2d>& normals, const std::vector<int>& idx);
/// split_normals on angles prepared by normal_angles.
bool split_normals(const std::vector<Vec2d>& normals, const NormalAngles& angles, int k, double min_angle,
                   int min_size, std::vector<std::vector<int>>& parts);

/// What a local fit sees: the data and the support circle (centre, radius),
/// and how its error is measured (fit/mpu.h, "What tol bounds").
struct FitInput {
  const std::vector<Vec2d>& points;
  const std::vector<Vec2d>& normals;
  Vec2d centre;
  double radius;
  double corner_angle;  ///< radians, MpuParams::corner_angle
  double link = 0.0;    ///< points closer than this are connected (MpuParams::component_link x spacing)
  /// > 0: a point's error counts by min(1, w(p) / weight_ref), its weight in
  /// this leaf relative to the weight the leaf has a little beyond its own
  /// cell (kFullErrorReach; MpuParams::weighted_error); 0: every support point
  /// counts fully (MPU).
  double weight_ref = 0.0;
  /// MPU weight of a point: b(3 |p - centre| / (2 radius)), floored at 1e-12
  /// so that points on the circle itself still count a little.
  [[nodiscard]] double weight(const Vec2d& p) const;
  /// The error of fn over the points ids: max over them of
  /// Taubin distance x (weighted share, above). Stops once it
  /// exceeds `bound` (returning a value > bound): callers that only keep a
  /// candidate beating the best so far pass that best.
  [[nodiscard]] double error(const LocalFn& fn, const std::vector<int>& ids,
                             double bound = std::numeric_limits<double>::infinity()) const;
};

/// Least points per corner cluster: a quadratic needs 3, one more tolerates a
/// stray normal (docs/decisions.md: departures from MPU).
inline constexpr int kMinClusterSize = 4;

/// Height function (if all normals lie within 90 degrees of their mean) or conic, the better.
CurvePiece fit_piece(const FitInput& in, const std::vector<int>& ids, double& error);

/// Corner: ids split by split_normals into k (2 or 3) clusters, each cluster
/// split further into its connected parts (links shorter than in.link: two
/// parallel sides with one normal direction are two parts); 2 or 3 parts in
/// all, else false. A piece (fit_piece) per part. Two pieces: min if convex
/// (each part lies behind the other's mean normal), else max. Three: the
/// min / max combination (Group::Op) with the least Taubin error over ids.
/// `angles`: normal_angles(in.normals, ids) if the caller has them.
bool fit_corner(const FitInput& in, const std::vector<int>& ids, int k, Group& group,
                const NormalAngles* angles = nullptr);

/// fit_piece, else fit_corner with 2, then 3 pieces; the first within tol.
Group fit_curve(const FitInput& in, const std::vector<int>& ids, double tol, double& error);

/// A group per part, joined bottom-up by the least-error pair and min/max
/// (min: hole in a region, thin wall; max: across a gap). \pre 2 to kMaxComponents parts.
LocalFn fit_components(const FitInput& in, const std::vector<std::vector<int>>& parts, double tol);

}  // namespace isoloft::detail
