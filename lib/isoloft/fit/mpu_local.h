// Local approximations of the 2D MPU curve (fit/mpu.h): the three kinds of
// Ohtake et al. 2003, section 3 (height function, general quadric, sharp
// feature), reduced from surfaces in 3D to curves in 2D, and their min/max
// joins over connected pieces of data. All are positive inside (the input
// normals point outward) and are written so that Q is in pixels and
// |grad Q| ~ 1 on the data, i.e. Q ~ signed distance near the curve.
// Internals of fit_mpu, exposed for the tests.
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include "isoloft/core/mesh.h"

namespace isoloft::detail {

/// Quadratic B-spline of MPU, b(t) = 3/4 - t^2 (|t| <= 1/2), (3/2 - |t|)^2 / 2
/// (1/2 <= |t| <= 3/2), 0 beyond; the weight of a ball (c, R) is
/// b(3 |x - c| / (2 R)), zero outside the ball.
double bspline2(double t);
/// b'(t) for t >= 0.
double bspline2_derivative(double t);

/// A height function over a line (MPU "bivariate quadratic polynomial in local
/// coordinates", 2D): w = h(u) = S (a s^2 + b s + c), s = u / S, with
/// u = t . (x - o), w = n . (x - o), n the outward mean normal. Q = h(u) - w.
struct HeightFn {
  Vec2d o{0.0, 0.0}, n{0.0, 1.0}, t{-1.0, 0.0};
  double scale = 1.0;
  double a = 0.0, b = 0.0, c = 0.0;
  void eval(const Vec2d& x, double& value, Vec2d& grad) const;
};

/// A single smooth piece: a height function or a general conic.
struct CurvePiece {
  bool conic = false;
  HeightFn h;  ///< when !conic
  /// When conic: Q(x) = S (q0 s_x^2 + q1 s_x s_y + q2 s_y^2 + q3 s_x + q4 s_y + q5),
  /// s = (x - centre) / S.
  Vec2d centre{0.0, 0.0};
  double scale = 1.0;
  std::array<double, 6> q{};
  void eval(const Vec2d& x, double& value, Vec2d& grad) const;
};

/// Up to three pieces combined by min and max: a smooth curve piece, a
/// corner (MPU's sharp-feature "edge" function in 2D), or two corners in a
/// row (the end of a thin bar: min of three; a step: max(A, min(B, C))).
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

/// Largest number of connected pieces of data one local function combines.
inline constexpr int kMaxComponents = 4;

/// One local approximation Q_i: one group, or one group per connected piece
/// of the data in the support (up to kMaxComponents) joined by min and max.
struct LocalFn {
  enum class Kind : std::uint8_t {
    Quadric,     ///< MPU "general 3D quadric" in 2D: one conic
    Height,      ///< MPU "bivariate quadratic polynomial": one height function
    Corner,      ///< MPU "sharp feature" in 2D: pieces split by normals, by min/max
    Components,  ///< one group per connected piece of data, joined by min/max
  };
  /// Node groups + j of the join tree: min or max of nodes a and b (a node
  /// below `groups` is that group); the last node is the value.
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

/// Weighted least-squares height function over `normal` (unit, outward) with
/// origin `o`, scale `scale` (px), through points[idx[k]] with weights w[k].
HeightFn fit_height(const std::vector<Vec2d>& points, const std::vector<int>& idx, const std::vector<double>& w,
                    const Vec2d& o, const Vec2d& normal, double scale);

/// MPU auxiliary point: q and d(q), the mean of (p_k - q) . n_k over its 6
/// nearest data points (> 0: q lies behind the normals, i.e. inside).
struct AuxPoint {
  Vec2d q;
  double d;
};

/// Aux points nearer than this many pixels to a data point are not used as
/// sign checks: that near digitised data their side is noise.
inline constexpr double kSignCheckMargin = 2.0;

/// Weighted error (MpuParams::weighted_error): a support point's error counts
/// fully up to this multiple of the distance from a cell's centre to its
/// corners (in units of the weight argument t), and by the leaf's relative
/// weight beyond. A tenth beyond the corners: at 1.0 (the cell alone) the
/// larger leaves this allows raised the tilted-torus benchmark's mean surface
/// distance from 0.1414 to 0.1510 px; 1.1 gave 0.1414 and 1.2 0.1412, with
/// the frog labels' leaves within tol at 1.1 (5,845 leaves, 2 over tol, the
/// largest 1.50 px) and slightly less so at 1.2 (6,673, 5, 1.52 px).
inline constexpr double kFullErrorReach = 1.1;

/// Ring of sign checks around the data (fit/mpu.h): lattice points whose
/// nearest point lies this far, pixels. Near: twice tol (0.75 px), where a
/// curve holding its bound has the data's side; also where the sign guard's
/// pixels begin on the outside of a mask (2 px from a boundary pixel centre
/// is 1.5 px from its edge point). Far: the band a stray curve piece beside
/// the data would cross on its way out to the sign guard's pixels.
inline constexpr double kRingNear = 1.5, kRingFar = 3.0;
/// A sign check takes its side from its nearest point's tangent only if it
/// lies within this angle of that point's normal, radians (60 degrees: the
/// nearest point of a curve sees q along its normal; the angle allows for the
/// point spacing, ~14 degrees at 2 px, and for noisy normals).
inline constexpr double kSideAngle = M_PI / 3.0;

/// A grown cell is not subdivided if its support radius exceeds this fraction
/// of its parent's (an ungrown child has half its parent's radius): the
/// children would hold about the same points, so no error could drop.
inline constexpr double kSupportShrink = 0.8;

/// Offset of the auxiliary off-surface points p -/+ delta n (values +/- delta)
/// of a general conic, pixels. They enter as their central difference, which
/// for a conic is exactly grad Q(p) . n = -1 (orientation and scale, which the
/// point term alone leaves free: it is minimised by Q = 0); delta sets the
/// weight of that condition against the point term (residuals in pixels): 1
/// px, the resolution of the data.
inline constexpr double kOffSurfaceDelta = 1.0;

/// General conic by weighted least squares on the points and their
/// off-surface pairs (MPU's 3D quadric fit with the auxiliary values moved
/// out to sign checks, see fit/mpu.h):
///   sum w_k [Q(p_k)^2 + ((Q(p_k - delta n_k) - Q(p_k + delta n_k)) / 2 - delta)^2].
CurvePiece fit_conic(const std::vector<Vec2d>& points, const std::vector<Vec2d>& normals, const std::vector<int>& idx,
                const std::vector<double>& w, const Vec2d& centre, double scale);

/// Max over idx of the Taubin distance |Q(p)| / |grad Q(p)| (first-order
/// Euclidean distance from p to the zero set of Q).
double taubin_error(const LocalFn& fn, const std::vector<Vec2d>& points, const std::vector<int>& idx);

/// Split of the normals of points idx into k (2 or 3) clusters: the unit
/// normals' angles are cut open at their largest gap on the circle and split
/// by optimal 1D k-means (each cluster is then an arc of directions), in
/// angular order. Returns false if a cluster has fewer than `min_size` points
/// or two neighbouring clusters' mean directions are closer than `min_angle`
/// (radians).
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

/// Clusters of a corner split need this many points: a quadratic needs 3,
/// one more tolerates a stray normal; a support of 8 points can then hold a
/// corner (with 6 here, on the frog labels at n_floor 8: 26 leaves over tol
/// up to 1.48 px; with 4: 13, up to 1.35 px).
inline constexpr int kMinClusterSize = 4;

/// Best single piece for the points ids: a height function over their weighted
/// mean normal (if every normal is within 90 degrees of it) or a conic,
/// whichever has the smaller Taubin error over ids (returned in `error`).
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

/// Best group for ids: fit_piece, or fit_corner (2, then 3 pieces) if that
/// has a smaller error; stops at the first within `tol`.
Group fit_curve(const FitInput& in, const std::vector<int>& ids, double tol, double& error);

/// One group per part (fit_curve each), joined bottom-up: each step joins
/// the two nodes, by min or by max, whose join has the least Taubin error over
/// their points (min where each lies inside the other: a hole in a region, a
/// thin wall; max where neither does: regions across a gap, an island in a
/// hole). \pre 2 <= parts.size() <= kMaxComponents.
LocalFn fit_components(const FitInput& in, const std::vector<std::vector<int>>& parts, double tol);

}  // namespace isoloft::detail
