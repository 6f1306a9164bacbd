// Local approximations of the 2D MPU curve (fit/mpu.h): the three kinds of
// Ohtake et al. 2003, section 3, reduced from surfaces in 3D to curves in 2D.
// All are positive inside (the input normals point outward) and are written so
// that Q is in pixels and |grad Q| ~ 1 on the data, i.e. Q ~ signed distance
// near the curve. Internals of fit_mpu, exposed for the tests.
#pragma once

#include <array>
#include <cstdint>
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
struct Piece {
  bool conic = false;
  HeightFn h;  ///< when !conic
  /// When conic: Q(x) = S (q0 s_x^2 + q1 s_x s_y + q2 s_y^2 + q3 s_x + q4 s_y + q5),
  /// s = (x - centre) / S.
  Vec2d centre{0.0, 0.0};
  double scale = 1.0;
  std::array<double, 6> q{};
  void eval(const Vec2d& x, double& value, Vec2d& grad) const;
};

/// One or two pieces combined by min or max: a smooth curve piece, or a
/// corner (MPU's sharp-feature "edge" function in 2D).
struct Group {
  std::array<Piece, 2> piece{};
  int count = 1;        ///< pieces used (1 or 2)
  bool use_min = true;  ///< two pieces: min (the inside is inside both) or max (inside either)
  void eval(const Vec2d& x, double& value, Vec2d& grad) const;
};

/// One local approximation Q_i: one group, or two groups (the two largest
/// connected pieces of the data in the support) combined by min or max.
struct LocalFn {
  enum class Kind : std::uint8_t {
    Quadric,    ///< MPU "general 3D quadric" in 2D: one conic
    Height,     ///< MPU "bivariate quadratic polynomial": one height function
    Corner,     ///< MPU "sharp feature" in 2D: two pieces split by normals, min/max
    TwoCurves,  ///< two connected pieces of data (e.g. the sides of a gap), min/max
  };
  Kind kind = Kind::Height;
  std::array<Group, 2> group{};
  int groups = 1;
  bool use_min = true;  ///< two groups: min or max
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

/// Aux points with |d| below this many pixels are not used as sign checks:
/// nearer than that to digitised data the sign of d is noise.
inline constexpr double kSignCheckMargin = 2.0;

/// A grown cell is not subdivided if its support radius exceeds this fraction
/// of its parent's (an ungrown child has half its parent's radius): the
/// children would hold about the same points, so no error could drop.
inline constexpr double kSupportShrink = 0.8;

/// Offset of the auxiliary off-surface points p -/+ delta n (targets +/- delta)
/// added for every support point of a general quadric, pixels. They fix the
/// orientation and scale (|grad Q| ~ 1) that the point term alone leaves free
/// (it is minimised by Q = 0); one pixel is the resolution of the data, small
/// enough that the O(delta^2 curvature) error of a quadric is negligible.
inline constexpr double kOffSurfaceDelta = 1.0;

/// General conic by weighted least squares on the points and their
/// off-surface points (MPU's 3D quadric fit with the auxiliary values moved
/// out to sign checks, see fit/mpu.h):
///   sum w_k [Q(p_k)^2 + (Q(p_k - delta n_k) - delta)^2 + (Q(p_k + delta n_k) + delta)^2].
Piece fit_conic(const std::vector<Vec2d>& points, const std::vector<Vec2d>& normals, const std::vector<int>& idx,
                const std::vector<double>& w, const Vec2d& centre, double scale);

/// Max over idx of the Taubin distance |Q(p)| / |grad Q(p)| (first-order
/// Euclidean distance from p to the zero set of Q).
double taubin_error(const LocalFn& fn, const std::vector<Vec2d>& points, const std::vector<int>& idx);

/// Split of the normals of points idx into two clusters: the unit normals'
/// angles are cut open at their largest gap on the circle and split by optimal
/// 1D 2-means (both clusters are then arcs of directions). Returns false if a
/// cluster has fewer than `min_size` points or the clusters' mean directions
/// are closer than `min_angle` (radians).
bool split_normals(const std::vector<Vec2d>& normals, const std::vector<int>& idx, double min_angle, int min_size,
                   std::vector<int>& first, std::vector<int>& second);

/// What a local fit sees: the data and the support circle (centre, radius).
struct FitInput {
  const std::vector<Vec2d>& points;
  const std::vector<Vec2d>& normals;
  Vec2d centre;
  double radius;
  double corner_angle;  ///< radians, MpuParams::corner_angle
  /// MPU weight of a point: b(3 |p - centre| / (2 radius)), floored at 1e-12
  /// so that points on the circle itself still count a little.
  [[nodiscard]] double weight(const Vec2d& p) const;
};

/// Clusters of a corner split need this many points: a quadratic needs 3,
/// 6 tolerates a few stray normals.
inline constexpr int kMinClusterSize = 6;

/// Best single piece for the points ids: a height function over their weighted
/// mean normal (if every normal is within 90 degrees of it) or a conic,
/// whichever has the smaller Taubin error over ids (returned in `error`).
Piece fit_piece(const FitInput& in, const std::vector<int>& ids, double& error);

/// Corner: ids split by split_normals, a piece (fit_piece) per cluster,
/// combined by min if convex (each cluster lies behind the other's mean
/// normal), else max. False if the normals do not split.
bool fit_corner(const FitInput& in, const std::vector<int>& ids, Group& group);

/// Best group for ids: fit_piece, or fit_corner if that has a smaller error.
Group fit_curve(const FitInput& in, const std::vector<int>& ids, double& error);

/// Two groups (fit_curve each) combined by min if each lies inside the other's
/// function on average (nested: a hole in a region, a thin wall), else max
/// (side by side: two regions across a gap).
LocalFn fit_two_curves(const FitInput& in, const std::vector<int>& a, const std::vector<int>& b);

}  // namespace isoloft::detail
