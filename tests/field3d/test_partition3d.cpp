// @file tests/field3d/test_partition3d.cpp
// @brief Touching labels as one partition: two boxes and two hemispheres
// drawn on a few planes; no point inside both meshes, no gap between them
// (along rays), the shared patch's vertices the same points in both, each
// mesh closed and oriented; labels apart solved alone as before.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>

#include "isoloft/core/error.h"
#include "isoloft/field3d/partition3d.h"

namespace isoloft {
namespace {

PlanePose pose(const Vec3d& origin, const Vec3d& u, const Vec3d& v) {
  PlanePose p;
  p.origin = origin;
  p.u = u;
  p.v = v;
  return p;
}

/// The part of the closed in-plane polygon `poly` where world x * side <= 0
/// (Sutherland-Hodgman against one line).
std::vector<Vec2d> clip_x(const std::vector<Vec2d>& poly, const PlanePose& ps, double side) {
  const auto h = [&](const Vec2d& p) { return side * ps.to_world(p).x(); };
  std::vector<Vec2d> out;
  for (std::size_t i = 0; i < poly.size(); ++i) {
    const Vec2d &a = poly[i], &b = poly[(i + 1) % poly.size()];
    const double ha = h(a), hb = h(b);
    if (ha <= 0) out.push_back(a);
    if ((ha < 0 && hb > 0) || (ha > 0 && hb < 0)) out.push_back(a + (b - a) * (ha / (ha - hb)));
  }
  return out;
}

/// Label 1 is the shape's part at x <= 0, label 2 at x >= 0, on each plane:
/// `loop` gives the shape's section there (in-plane mm), empty if none.
template <class Loop>
std::vector<Section> split_sections(const std::vector<PlanePose>& poses, const Loop& loop) {
  std::vector<Section> out;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    Section s;
    s.pose = poses[i];
    s.source = "split plane " + std::to_string(i);
    const std::vector<Vec2d> whole = loop(poses[i]);
    for (std::uint32_t label : {1u, 2u}) {
      std::vector<Vec2d> part = clip_x(whole, poses[i], label == 1 ? 1.0 : -1.0);
      if (part.size() >= 3) s.contours.push_back({std::move(part), label, false});
    }
    out.push_back(std::move(s));
  }
  return out;
}

/// The box [-20, 20] x [-15, 15] x [-12, 12] mm on axial, coronal and
/// sagittal planes (none on x = 0, the shared face).
std::vector<Section> two_boxes() {
  const Vec3d X = Vec3d::UnitX(), Y = Vec3d::UnitY(), Z = Vec3d::UnitZ();
  const std::vector<PlanePose> poses{pose({0, 0, -8}, X, Y), pose({0, 0, 0}, X, Y), pose({0, 0, 8}, X, Y),
                                     pose({0, 0, 0}, X, Z), pose({-10, 0, 0}, Y, Z), pose({10, 0, 0}, Y, Z)};
  return split_sections(poses, [](const PlanePose& p) {
    const Vec3d hi(20, 15, 12);
    const Vec2d a(hi.dot(p.u.cwiseAbs()), hi.dot(p.v.cwiseAbs()));  // half sides along u and v
    return std::vector<Vec2d>{{-a.x(), -a.y()}, {a.x(), -a.y()}, {a.x(), a.y()}, {-a.x(), a.y()}};
  });
}

/// A sphere of radius 25 mm about the origin on axial planes, a coronal one
/// and sagittal ones off x = 0; 360 vertices a circle.
std::vector<Section> two_hemispheres() {
  const Vec3d X = Vec3d::UnitX(), Y = Vec3d::UnitY(), Z = Vec3d::UnitZ();
  const std::vector<PlanePose> poses{pose({0, 0, -15}, X, Y), pose({0, 0, 0}, X, Y), pose({0, 0, 15}, X, Y),
                                     pose({0, 0, 0}, X, Z), pose({-12, 0, 0}, Y, Z), pose({12, 0, 0}, Y, Z)};
  return split_sections(poses, [](const PlanePose& p) {
    constexpr double R = 25;
    const double d = p.origin.norm();  // every pose's origin is its plane's point nearest the centre
    const double r = std::sqrt(R * R - d * d);
    std::vector<Vec2d> c;
    for (int k = 0; k < 360; ++k) c.emplace_back(r * std::cos(2 * M_PI * k / 360), r * std::sin(2 * M_PI * k / 360));
    return c;
  });
}

/// Where the line (y, z) = const crosses `mesh`'s triangles, x sorted.
std::vector<double> ray_crossings(const TriMesh& mesh, double y, double z) {
  std::vector<double> xs;
  for (const auto& t : mesh.triangles) {
    const Vec3d a = mesh.vertices[std::size_t(t[0])].cast<double>(), b = mesh.vertices[std::size_t(t[1])].cast<double>(),
                c = mesh.vertices[std::size_t(t[2])].cast<double>();
    // Barycentric coordinates of (y, z) in the triangle projected on the yz plane.
    const double det = (b.y() - a.y()) * (c.z() - a.z()) - (c.y() - a.y()) * (b.z() - a.z());
    if (det == 0) continue;
    const double s = ((y - a.y()) * (c.z() - a.z()) - (c.y() - a.y()) * (z - a.z())) / det;
    const double r = ((b.y() - a.y()) * (z - a.z()) - (y - a.y()) * (b.z() - a.z())) / det;
    if (s < 0 || r < 0 || s + r > 1) continue;
    xs.push_back(a.x() + s * (b.x() - a.x()) + r * (c.x() - a.x()));
  }
  std::sort(xs.begin(), xs.end());
  return xs;
}

/// Length of the intersection of two sets of intervals given as sorted
/// crossing pairs.
double common_length(const std::vector<double>& a, const std::vector<double>& b) {
  double len = 0;
  for (std::size_t i = 0; i + 1 < a.size(); i += 2)
    for (std::size_t j = 0; j + 1 < b.size(); j += 2)
      len += std::max(0.0, std::min(a[i + 1], b[j + 1]) - std::max(a[i], b[j]));
  return len;
}

struct RayStats {
  double overlap = 0;  ///< volume inside both meshes, mm^3
  double gap = 0;      ///< volume between label 1's last crossing and label 2's first on rays through both, mm^3
  long odd = 0;        ///< rays crossing a mesh an odd number of times (0 for closed meshes)
  long shared = 0;     ///< rays through both meshes
};

/// Rays along x on a lattice of `step` mm over the yz square of side 2 half
/// (offsets avoid the grid's planes, where a ray would graze mesh edges);
/// gaps counted on rays within `inner` of the x axis only (rim below).
RayStats rays(const TriMesh& m1, const TriMesh& m2, double half, double inner, double step) {
  RayStats s;
  for (double y = -half + 0.3137; y < half; y += step)
    for (double z = -half + 0.1723; z < half; z += step) {
      const std::vector<double> a = ray_crossings(m1, y, z), b = ray_crossings(m2, y, z);
      if (a.size() % 2 || b.size() % 2) {
        ++s.odd;
        continue;
      }
      s.overlap += common_length(a, b) * step * step;
      if (a.empty() || b.empty() || std::abs(y) > inner || std::abs(z) > inner) continue;
      ++s.shared;
      s.gap += std::max(0.0, b.front() - a.back()) * step * step;
    }
  return s;
}

/// Vertices of `from` within `slab` mm of x = 0 and inside |y|, |z| <= `inner`:
/// how many, and how many have no vertex of `to` at exactly the same point.
std::pair<long, long> unmatched_patch_vertices(const TriMesh& from, const TriMesh& to, double slab, double inner) {
  std::map<std::array<float, 3>, int> at;
  for (const Vec3f& v : to.vertices) at[{v.x(), v.y(), v.z()}] = 1;
  long n = 0, missing = 0;
  for (const Vec3f& v : from.vertices) {
    if (std::abs(v.x()) > slab || std::abs(v.y()) > inner || std::abs(v.z()) > inner) continue;
    ++n;
    missing += !at.count({v.x(), v.y(), v.z()});
  }
  return {n, missing};
}

/// A coarser grid than the default 96 cells: the properties checked hold at
/// any resolution, and a unit test stays short.
Field3dParams test_params() {
  Field3dParams p;
  p.resolution = 48;
  return p;
}

/// `inner`: the shared face's part checked (|y|, |z| <= inner), away from its
/// rim and, for the boxes, from the extrapolated caps, where both fields dip
/// below 0 on the face (docs/decisions.md: touching labels).
void check_partition(const std::vector<Section>& sections, double half, double inner) {
  const Partition3dResult r = reconstruct_partition(sections, {1, 2}, test_params());
  ASSERT_EQ(r.objects.size(), 2u);
  ASSERT_EQ(r.groups.size(), 1u) << "the two labels touch: one group";
  for (const Partition3dObject& ob : r.objects) {
    EXPECT_TRUE(ob.check.closed) << "label " << ob.label;
    EXPECT_TRUE(ob.check.oriented) << "label " << ob.label;
    EXPECT_TRUE(ob.check.manifold) << "label " << ob.label;
    EXPECT_EQ(ob.check.components, 1) << "label " << ob.label;
    EXPECT_EQ(ob.check.euler, 2) << "label " << ob.label;
    EXPECT_GT(ob.check.volume, 0) << "label " << ob.label;
  }
  // The shared face: every vertex near x = 0 away from the rim is one point of both meshes.
  // The drawings are mirror images about x = 0, so the shared face lies on it
  // (its vertices within 1e-4 of a cell, kMinEdgeFraction, of the grid nodes there).
  const double slab = 1e-3;
  for (int k = 0; k < 2; ++k) {
    const auto [n, missing] = unmatched_patch_vertices(r.objects[k].mesh, r.objects[1 - k].mesh, slab, inner);
    EXPECT_GT(n, 50) << "label " << k + 1 << ": too few vertices on the shared face";
    EXPECT_EQ(missing, 0) << "label " << k + 1 << ": of " << n;
  }
  // No point claimed twice, no gap: along rays on a 0.5 mm lattice. Gaps
  // only away from the rim: there each label's field rounds its own edge
  // (the rule puts the groove between them outside; docs/decisions.md).
  const RayStats s = rays(r.objects[0].mesh, r.objects[1].mesh, half, inner, 0.5);
  EXPECT_EQ(s.odd, 0);
  EXPECT_GT(s.shared, 100);
  const double v = r.objects[0].check.volume + r.objects[1].check.volume;
  /// Both meshes cross each ray at the same float x on the shared face
  /// (their triangles there have the same vertices), so overlap and gap are
  /// float rounding of the crossings: 1e-6 of the volume is ~1e-5 mm a ray.
  constexpr double kRayRounding = 1e-6;
  EXPECT_LE(s.overlap, kRayRounding * v) << "volume " << v;
  EXPECT_LE(s.gap, kRayRounding * v) << "volume " << v;
}

TEST(Partition3d, TwoTouchingBoxes) { check_partition(two_boxes(), 25, 6); }

TEST(Partition3d, TwoTouchingHemispheres) { check_partition(two_hemispheres(), 30, 12); }

/// Labels whose grids do not overlap are solved alone: the same meshes as
/// reconstruct_sections() gives each.
TEST(Partition3d, LabelsApartSolvedAlone) {
  std::vector<Section> sections = two_boxes();
  for (Section& s : sections)
    for (SectionContour& c : s.contours)
      if (c.label == 2)
        for (Vec2d& p : c.points) p += s.pose.to_plane(s.pose.origin + Vec3d(60, 0, 0)) - s.pose.to_plane(s.pose.origin);
  // Moving label 2 by 60 mm in x leaves it on the planes normal to y and z only.
  std::vector<Section> kept;
  for (Section& s : sections)
    if (std::abs(s.pose.normal().x()) < 0.5) kept.push_back(s);
  const Partition3dResult r = reconstruct_partition(kept, {1, 2}, test_params());
  ASSERT_EQ(r.groups.size(), 2u);
  for (std::size_t k = 0; k < 2; ++k) {
    const Field3dResult alone = reconstruct_sections(kept, r.objects[k].label, test_params());
    ASSERT_EQ(r.objects[k].mesh.vertices.size(), alone.mesh.vertices.size()) << "label " << k + 1;
    for (std::size_t i = 0; i < alone.mesh.vertices.size(); ++i)
      ASSERT_EQ(r.objects[k].mesh.vertices[i], alone.mesh.vertices[i]) << "label " << k + 1 << " vertex " << i;
  }
}

TEST(Partition3d, BadLabelList) {
  const std::vector<Section> s = two_boxes();
  EXPECT_THROW((void)reconstruct_partition(s, {}), ParamError);
  EXPECT_THROW((void)reconstruct_partition(s, {1, 1}), ParamError);
  try {
    (void)reconstruct_partition(s, {1, 3}, test_params());
    ADD_FAILURE() << "no error for label 3, drawn nowhere";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("label 3"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace isoloft
