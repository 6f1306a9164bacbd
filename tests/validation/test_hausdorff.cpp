// Tests of validation/hausdorff.h on meshes with known distances: icospheres
// (vertices on the sphere, faces inside it by at most their sagitta), in the
// style of CGAL's bounded-error Hausdorff test: the fast (CGAL + AABB tree)
// and the naive (brute force) versions run on the same cases and must agree
// within their bounds, and both must contain the analytic value.
#if defined(ISOLOFT_HAVE_VALIDATION)

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include "isoloft/core/error.h"
#include "isoloft/synth/shapes.h"
#include "validation/hausdorff.h"

namespace isoloft {
namespace {

// Mesh vertices are floats: coordinates <= 40 px round by <= 2.4e-6 px.
constexpr double kFloatTol = 1e-5;

// Icosahedron subdivided `level` times, vertices projected onto the sphere;
// counter-clockwise seen from outside.
TriMesh icosphere(const Vec3d& c, double r, int level) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Vec3d> v = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                          {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  std::vector<std::array<int, 3>> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                       {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                       {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                       {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (auto& p : v) p.normalize();
  for (int l = 0; l < level; ++l) {
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      const auto key = std::minmax(a, b);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      v.push_back((v[a] + v[b]).normalized());
      return mid[key] = int(v.size()) - 1;
    };
    std::vector<std::array<int, 3>> g;
    for (const auto& [a, b, cc] : f) {
      const int ab = midpoint(a, b), bc = midpoint(b, cc), ca = midpoint(cc, a);
      g.push_back({a, ab, ca});
      g.push_back({b, bc, ab});
      g.push_back({cc, ca, bc});
      g.push_back({ab, bc, ca});
    }
    f = std::move(g);
  }
  TriMesh m;
  for (const auto& p : v) m.vertices.push_back((c + r * p).cast<float>());
  for (const auto& [a, b, cc] : f) m.triangles.push_back({a, b, cc});
  return m;
}

// Largest gap between the sphere and the mesh: r minus the least distance
// from the centre to a face plane (every face contains its plane's foot).
double max_sagitta(const TriMesh& m, const Vec3d& c, double r) {
  double s = 0;
  for (const auto& t : m.triangles) {
    const Vec3d a = m.vertices[t[0]].cast<double>(), b = m.vertices[t[1]].cast<double>(),
                d = m.vertices[t[2]].cast<double>();
    const Vec3d n = (b - a).cross(d - a).normalized();
    s = std::max(s, r - std::abs(n.dot(a - c)));
  }
  return s;
}

bool contains(const HausdorffInterval& h, double v, double tol) { return h.lower - tol <= v && v <= h.upper + tol; }
std::string str(const HausdorffInterval& h) {
  return "[" + std::to_string(h.lower) + ", " + std::to_string(h.upper) + "]";
}

TEST(Hausdorff, ConcentricSpheresFastAndNaiveAgree) {
  // A (radius 8) and B (radius 8.5): every point of A is between 0.5 - s_B
  // and 0.5 + s_A from B (s = sagitta), and the same for B -> A.
  constexpr double kRa = 8.0, kRb = 8.5, kError = 0.01;
  constexpr double kNaiveSpacing = 0.5;  // naive upper bound slack <= 0.5 / sqrt(3) px
  // The distance from A to the scaled copy B is nearly constant (parallel
  // faces 0.5 cos(beta) apart), so a sampled max misses the true one by far
  // less than this.
  constexpr double kSampledMaxGap = 0.005;
  const Vec3d c(20.3, 19.6, 12.1);
  const TriMesh a = icosphere(c, kRa, 3), b = icosphere(c, kRb, 3);
  const double sa = max_sagitta(a, c, kRa), sb = max_sagitta(b, c, kRb);
  const HausdorffInterval analytic{0.5 - sb - kFloatTol, 0.5 + sa + kFloatTol};

  const MeshDistanceReport r = mesh_distance(a, b, kError);
  const HausdorffInterval naive_ab = detail::hausdorff_naive(a, b, kNaiveSpacing);
  const HausdorffInterval naive_ba = detail::hausdorff_naive(b, a, kNaiveSpacing);
  for (const auto& [name, fast, naive] : {std::tuple{"a->b", r.a_to_b, naive_ab}, std::tuple{"b->a", r.b_to_a, naive_ba}}) {
    SCOPED_TRACE(name);
    EXPECT_LE(fast.lower, fast.upper) << str(fast);
    // CGAL's bound: the interval is at most 2 error bounds wide.
    EXPECT_LE(fast.upper - fast.lower, 2 * kError + kFloatTol) << str(fast);
    // Both contain the true distance, so they overlap, and both overlap the analytic range.
    EXPECT_LE(std::max(fast.lower, naive.lower), std::min(fast.upper, naive.upper) + kFloatTol)
        << "fast " << str(fast) << " naive " << str(naive);
    EXPECT_LE(std::max(fast.lower, analytic.lower), std::min(fast.upper, analytic.upper))
        << "fast " << str(fast) << " analytic " << str(analytic);
    EXPECT_NEAR(fast.lower, naive.lower, 2 * kError + kSampledMaxGap) << "fast " << str(fast) << " naive " << str(naive);
    EXPECT_GE(fast.lower, analytic.lower) << str(fast);
    EXPECT_LE(fast.upper, analytic.upper + kError) << str(fast);
  }
  // Mean and p99 lie between the analytic extremes too.
  EXPECT_GE(r.mean_a_to_b, analytic.lower);
  EXPECT_LE(r.p99_a_to_b, r.a_to_b.upper);
  EXPECT_LE(r.mean_a_to_b, r.p99_a_to_b + kFloatTol);
}

TEST(Hausdorff, ExtraComponentIsOneSided) {
  // B = A plus a small far sphere: A -> B is 0, B -> A is the far sphere's
  // farthest point from A.
  constexpr double kError = 0.01;
  const Vec3d c(0, 0, 0), far(30, 0, 0);
  constexpr double kR = 6.0, kSmall = 2.0;
  const TriMesh a = icosphere(c, kR, 2);
  TriMesh b = a;
  const TriMesh extra = icosphere(far, kSmall, 2);
  for (const auto& t : extra.triangles)
    b.triangles.push_back({t[0] + int(a.vertices.size()), t[1] + int(a.vertices.size()), t[2] + int(a.vertices.size())});
  b.vertices.insert(b.vertices.end(), extra.vertices.begin(), extra.vertices.end());
  const MeshDistanceReport r = mesh_distance(a, b, kError);
  // A's faces all occur in B: CGAL culls them and returns 0, so [0, error bound].
  EXPECT_LE(r.a_to_b.upper, kError + kFloatTol) << str(r.a_to_b);
  // The far sphere's vertex (32, 0, 0) is 26 px from A's vertex (6, 0, 0), its
  // nearest point of A (A lies inside its sphere). Points of the far sphere just
  // off the x axis face A's slightly sunken faces and may be farther by
  // O(sagitta x angle) ~ 3e-4 px (level-2 faces, 6 px radius): allow 0.01 px.
  constexpr double kOffAxisGain = 0.01;
  EXPECT_GE(r.b_to_a.upper, 26.0 - kFloatTol) << str(r.b_to_a);
  EXPECT_LE(r.b_to_a.lower, 26.0 + kOffAxisGain) << str(r.b_to_a);
  EXPECT_LE(r.b_to_a.upper - r.b_to_a.lower, 2 * kError + kFloatTol) << str(r.b_to_a);
  EXPECT_EQ(hausdorff_verdict(r.a_to_b, 0.1), Verdict::Pass);
  EXPECT_EQ(hausdorff_verdict(r.b_to_a, 0.1), Verdict::Fail);
  EXPECT_EQ(hausdorff_verdict(r.symmetric(), 0.1), Verdict::Fail);
}

TEST(Hausdorff, VerdictLogic) {
  const HausdorffInterval h{0.4, 0.6};
  EXPECT_EQ(hausdorff_verdict(h, 0.6), Verdict::Pass);  // upper <= threshold
  EXPECT_EQ(hausdorff_verdict(h, 0.7), Verdict::Pass);
  EXPECT_EQ(hausdorff_verdict(h, 0.5), Verdict::Undecided);
  EXPECT_EQ(hausdorff_verdict(h, 0.4), Verdict::Undecided);  // lower not > threshold
  EXPECT_EQ(hausdorff_verdict(h, 0.39), Verdict::Fail);
  EXPECT_STREQ(to_string(Verdict::Undecided), "undecided");
}

TEST(Hausdorff, SampleMeshCoversAreaExactly) {
  const TriMesh m = icosphere(Vec3d(1, 2, 3), 5.0, 1);
  double area = 0;
  for (const auto& t : m.triangles) {
    const Vec3d a = m.vertices[t[0]].cast<double>();
    area += 0.5 * (m.vertices[t[1]].cast<double>() - a).cross(m.vertices[t[2]].cast<double>() - a).norm();
  }
  const detail::MeshSamples s = detail::sample_mesh(m, 0.3, 1'000'000);
  double sum = 0;
  for (const double w : s.weights) sum += w;
  constexpr double kAreaTol = 1e-9;  // relative: summation rounding only
  EXPECT_NEAR(sum, area, kAreaTol * area);
  // Every sample lies on its triangle's plane (a point of the mesh).
  for (std::size_t i = 0; i < s.points.size(); ++i) {
    if (s.face[i] < 0) continue;
    const auto& t = m.triangles[std::size_t(s.face[i])];
    const Vec3d a = m.vertices[t[0]].cast<double>();
    const Vec3d n = (m.vertices[t[1]].cast<double>() - a).cross(m.vertices[t[2]].cast<double>() - a).normalized();
    ASSERT_NEAR(n.dot(s.points[i] - a), 0.0, kFloatTol) << "sample " << i;
    ASSERT_LE(s.radius[i], 0.3 + kFloatTol) << "sample " << i;
  }
  // The cap raises the spacing instead of exceeding it.
  const detail::MeshSamples capped = detail::sample_mesh(m, 0.01, 5000);
  EXPECT_LE(long(capped.points.size()), 5000L);
}

TEST(Hausdorff, IcosphereAgainstTrueSphere) {
  constexpr double kR = 10.0;
  const Vec3d c(16.2, 15.8, 11.0);
  const TriMesh m = icosphere(c, kR, 3);
  const auto sphere = shape_from_json({{"type", "sphere"}, {"center", {c.x(), c.y(), c.z()}}, {"radius", kR}});
  // Both one-sided maxima equal the largest face sagitta: the face centre
  // farthest inside, and the sphere point above it.
  const double s = max_sagitta(m, c, kR);
  const TruthDistanceReport r = mesh_to_truth(m, *sphere, c.z() - 5.0, c.z() + 5.0);
  for (const auto* region : {&r.in_range, &r.caps}) {
    EXPECT_GT(region->mesh_to_truth.samples, 0);
    EXPECT_GT(region->truth_to_mesh.samples, 0);
    EXPECT_LE(region->mesh_to_truth.mean, region->mesh_to_truth.max.upper);
    EXPECT_LE(region->mesh_to_truth.max.lower, s + kFloatTol);
    EXPECT_LE(region->truth_to_mesh.max.lower, s + kFloatTol);
  }
  EXPECT_TRUE(contains(r.hausdorff, s, kFloatTol)) << str(r.hausdorff) << " sagitta " << s;
  // The mesh side is sampled at 0.5 px: upper - lower <= its sub-triangle radius.
  const HausdorffInterval m2t{std::max(r.in_range.mesh_to_truth.max.lower, r.caps.mesh_to_truth.max.lower),
                              std::max(r.in_range.mesh_to_truth.max.upper, r.caps.mesh_to_truth.max.upper)};
  EXPECT_TRUE(contains(m2t, s, kFloatTol)) << str(m2t);
  EXPECT_NEAR(m2t.lower, s, 0.01) << "a face centre is sampled within 0.01 px of its deepest point";
  // Face normals of a level-3 icosphere are within half an edge angle
  // (~0.14 rad / 2 ~ 4 degrees) of the sphere normals beneath them.
  constexpr double kMaxAngleDeg = 5.0;
  EXPECT_LT(r.in_range.mean_normal_angle_deg, kMaxAngleDeg);
  EXPECT_GT(r.in_range.mean_normal_angle_deg, 0.0);
  EXPECT_EQ(r.truth_spacing, TruthDistanceParams{}.truth_spacing) << "no cap reached";
}

TEST(Hausdorff, TruthSamplesCoverATiltedTorus) {
  // Every sample on the surface, and every point of the parameterised torus
  // within sqrt(3) h of a sample (the bound behind truth -> mesh upper ends).
  constexpr double kR = 12.0, kr = 4.0, kTilt = 60.0;
  const Vec3d c(20.0, 21.0, 18.0);
  const auto torus = shape_from_json({{"type", "torus"}, {"center", {c.x(), c.y(), c.z()}}, {"major_radius", kR},
                                      {"minor_radius", kr}, {"tilt_deg", kTilt}});
  double h = 0.5;
  const std::vector<Vec3d> s = detail::sample_shape_surface(*torus, h, 1'000'000);
  ASSERT_EQ(h, 0.5);
  constexpr double kOnSurface = 1e-9;  // closest_point of the exact torus: rounding only
  for (std::size_t i = 0; i < s.size(); ++i) ASSERT_LT(std::abs(torus->value(s[i])), kOnSurface) << "sample " << i;
  const Eigen::Matrix3d rot = Eigen::AngleAxisd(kTilt * M_PI / 180.0, Vec3d::UnitX()).toRotationMatrix();
  const double cover = std::sqrt(3.0) * h;
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 20; ++j) {
      const double u = 2 * M_PI * (i + 0.37) / 40, v = 2 * M_PI * (j + 0.61) / 20;
      const Vec3d p = c + rot * Vec3d((kR + kr * std::cos(v)) * std::cos(u), (kR + kr * std::cos(v)) * std::sin(u),
                                      kr * std::sin(v));
      double best = std::numeric_limits<double>::infinity();
      for (const Vec3d& q : s) best = std::min(best, (q - p).norm());
      ASSERT_LE(best, cover) << "torus point (u, v) = (" << u << ", " << v << ")";
    }
}

TEST(Hausdorff, BadInputThrows) {
  const TriMesh m = icosphere(Vec3d(0, 0, 0), 1.0, 0);
  EXPECT_THROW(mesh_distance(TriMesh{}, m, 0.1), InputError);
  EXPECT_THROW(mesh_distance(m, m, 0.0), ParamError);
  TriMesh bad = m;
  bad.triangles[3][1] = 99;
  EXPECT_THROW(mesh_distance(bad, m, 0.1), InputError);
  const auto sphere = shape_from_json({{"type", "sphere"}, {"center", {0, 0, 0}}, {"radius", 1.0}});
  EXPECT_THROW(mesh_to_truth(m, *sphere, 1.0, 0.0), ParamError);
}

TEST(Hausdorff, IdenticalMeshesAreAtDistanceZero) {
  const TriMesh m = icosphere(Vec3d(3, 4, 5), 4.0, 2);
  constexpr double kError = 0.001;
  const MeshDistanceReport r = mesh_distance(m, m, kError);
  EXPECT_EQ(r.cgal_a_to_b, 0.0) << "CGAL culls faces present in both meshes";
  EXPECT_LE(r.a_to_b.upper, kError + kFloatTol) << str(r.a_to_b);
  EXPECT_LE(r.b_to_a.upper, kError + kFloatTol) << str(r.b_to_a);
  EXPECT_LT(r.mean_a_to_b, kFloatTol);
}

}  // namespace
}  // namespace isoloft

#endif  // ISOLOFT_HAVE_VALIDATION
