// mesh/plane_cut.h: loops of a plane through closed meshes made by hand (a
// cube, a square tube), through vertices, and the orientation of islands and holes.
#include <gtest/gtest.h>

#include <cmath>

#include "isoloft/mesh/mesh_check.h"
#include "isoloft/mesh/plane_cut.h"

using namespace isoloft;

namespace {

double signed_area(const std::vector<Vec2d>& p) {
  double a = 0;
  for (std::size_t i = 0, j = p.size() - 1; i < p.size(); j = i++) a += p[j].x() * p[i].y() - p[i].x() * p[j].y();
  return 0.5 * a;
}

// An axis-aligned box as 12 triangles, counter-clockwise seen from outside;
// `inward` flips it (the inner wall of a tube).
void add_box(TriMesh& m, Vec3f lo, Vec3f hi, bool inward = false) {
  const std::int32_t b = std::int32_t(m.vertices.size());
  for (int i = 0; i < 8; ++i) m.vertices.emplace_back(i & 1 ? hi.x() : lo.x(), i & 2 ? hi.y() : lo.y(), i & 4 ? hi.z() : lo.z());
  const int faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& f : faces) {
    std::array<std::int32_t, 3> t0{b + f[0], b + f[1], b + f[2]}, t1{b + f[0], b + f[2], b + f[3]};
    if (inward) std::swap(t0[1], t0[2]), std::swap(t1[1], t1[2]);
    m.triangles.push_back(t0);
    m.triangles.push_back(t1);
  }
}

}  // namespace

TEST(PlaneCut, CubeGivesItsSquareCounterClockwise) {
  TriMesh m;
  add_box(m, {0, 0, 0}, {2, 3, 4});
  ASSERT_GT(check_mesh(m).volume, 0) << "the hand-made box is outward";
  const auto loops = cut_mesh(m, 1.5);
  ASSERT_EQ(loops.size(), 1u);
  EXPECT_NEAR(signed_area(loops[0]), 6.0, 1e-9) << "2 x 3, counter-clockwise seen from +z";
  for (const Vec2d& p : loops[0]) EXPECT_TRUE(p.x() == 0 || p.x() == 2 || p.y() == 0 || p.y() == 3) << p.transpose();
  EXPECT_TRUE(cut_mesh(m, 5.0).empty());
  EXPECT_TRUE(cut_mesh(m, 0.0).empty()) << "a plane through the bottom face: its vertices count as above";
  const auto top = cut_mesh(m, 4.0);  // through the top face's vertices: the loop of the triangles below
  ASSERT_EQ(top.size(), 1u);
  EXPECT_NEAR(signed_area(top[0]), 6.0, 1e-9);
}

// Two boxes and a hollow: islands counter-clockwise, a hole clockwise, so the
// even-odd rule and the signed areas agree.
TEST(PlaneCut, IslandsAndHolesKeepTheirOrientation) {
  TriMesh m;
  add_box(m, {0, 0, 0}, {10, 10, 2});
  add_box(m, {3, 3, -1}, {7, 7, 3}, /*inward=*/true);  // not a valid solid, but every loop is closed
  add_box(m, {20, 0, 0}, {21, 1, 2});
  const auto loops = cut_mesh(m, 1.0);
  ASSERT_EQ(loops.size(), 3u);
  double sum = 0;
  int negative = 0;
  for (const auto& l : loops) sum += signed_area(l), negative += signed_area(l) < 0;
  EXPECT_EQ(negative, 1) << "the hole";
  EXPECT_NEAR(sum, 100.0 - 16.0 + 1.0, 1e-9);
}

// A circle of radius R drawn with 720 points resampled at a 1 mm step: about
// 2 pi R points, all on the circle, and the deviation of the drawn points
// from the chords what geometry says: the sagitta R (1 - cos(pi / n)) at
// most, within kChordSlack (the drawn polygon is itself a chord polygon).
constexpr double kChordSlack = 1e-3;

TEST(PlaneCut, ResampledCircleHasItsStepAndChordDeviation) {
  const double r = 20;
  std::vector<Vec2d> circle;
  for (int i = 0; i < 720; ++i) circle.emplace_back(r * std::cos(2 * M_PI * i / 720.0), r * std::sin(2 * M_PI * i / 720.0));
  const ResampledLoop rs = resample_loop(circle, 1.0);
  const auto expected = std::size_t(std::lround(2 * M_PI * r * std::cos(M_PI / 720.0)));  // the polygon's length
  EXPECT_EQ(rs.points.size(), expected);
  for (std::size_t i = 0; i < rs.points.size(); ++i) EXPECT_NEAR(rs.points[i].norm(), r, 1e-3) << "point " << i;
  const double sagitta = r * (1 - std::cos(M_PI / double(rs.points.size())));
  EXPECT_LE(rs.max_deviation, sagitta + kChordSlack);
  EXPECT_GE(rs.max_deviation, 0.5 * sagitta) << "the drawn points between the chords' ends lie off them";
  EXPECT_LE(rs.mean_deviation, rs.max_deviation);
  EXPECT_NEAR(loop_area(rs.points), M_PI * r * r, 0.01 * M_PI * r * r);
  EXPECT_NEAR(mean_point_spacing({rs.points}), 1.0, 0.01);
  // A step longer than the loop: not 3 points (a triangle keeps 41 % of a
  // circle) but the fewest whose regular polygon keeps kResampleAreaShare of
  // the area: n sin(2 pi / n) / (2 pi) >= 1 - share, n = 19 for 2 %.
  const ResampledLoop few = resample_loop(circle, 1000.0);
  std::size_t least = 3;
  while (least * std::sin(2 * M_PI / double(least)) / (2 * M_PI) < 1 - kResampleAreaShare) ++least;
  EXPECT_NEAR(double(few.points.size()), double(least), 1.0) << "the 720-gon is a circle within 0.001 %";
  EXPECT_NEAR(loop_area(few.points), loop_area(circle), kResampleAreaShare * loop_area(circle));
  // A loop too short to resample comes back as given.
  EXPECT_EQ(resample_loop({{0, 0}, {1, 0}}, 0.1).points.size(), 2u);
  EXPECT_EQ(resample_loop(circle, 0.0).points.size(), circle.size());
}

TEST(PlaneCut, VolumeAboveAPlaneOfABoxAndABlockWithAShaft) {
  TriMesh box;
  add_box(box, {0, 0, 0}, {2, 3, 4});
  EXPECT_NEAR(volume_above(box, -1e9), 24.0, 1e-9);
  EXPECT_NEAR(volume_above(box, 1.0), 18.0, 1e-9);
  EXPECT_NEAR(volume_above(box, 4.0), 0.0, 1e-9);
  EXPECT_NEAR(volume_above(box, 0.0), 24.0, 1e-9) << "a plane through the bottom face: all of it";
  // A box with an inward box inside (a 4x4 block less a 2x2 shaft, height 4):
  // 48, a quarter of it above z = 3.
  TriMesh tube;
  add_box(tube, {0, 0, 0}, {4, 4, 4});
  add_box(tube, {1, 1, 0}, {3, 3, 4}, true);  // the hole as an inward box: volumes add with their sign
  const double whole = volume_above(tube, -1e9);
  EXPECT_NEAR(whole, 48.0, 1e-9);
  EXPECT_NEAR(volume_above(tube, 3.0), 12.0, 1e-9);
}

TEST(PlaneCut, DistanceToALoopAndItsArea) {
  const std::vector<Vec2d> sq{{0, 0}, {2, 0}, {2, 2}, {0, 2}};
  EXPECT_DOUBLE_EQ(loop_area(sq), 4.0);
  EXPECT_DOUBLE_EQ(loop_area({sq.rbegin(), sq.rend()}), -4.0);
  EXPECT_DOUBLE_EQ(distance_to_loop({1, 1}, sq), 1.0);
  EXPECT_DOUBLE_EQ(distance_to_loop({3, 1}, sq), 1.0);
  EXPECT_DOUBLE_EQ(distance_to_loop({-1, 0.5}, sq), 1.0) << "the closing edge counts";
  EXPECT_TRUE(std::isinf(distance_to_loop({0, 0}, {})));
}

// An island of 2.3 mm^2 as the mesh cuts it (a square of 1.52 mm with its
// corners cut, 12 vertices, as Lt Lung's 4-point islands on the shared RT
// set), resampled at the 1.7 mm step of its plane: at max(3, round(length /
// step)) = 3 points it kept 40 % of its area; now points are added until the
// area is within kResampleAreaShare, and every point stays on the loop.
TEST(PlaneCut, ResamplingASmallIslandKeepsItsArea) {
  const double h = 0.76, c = 0.25;  // half side, corner cut (mm)
  const std::vector<Vec2d> island{{-h + c, -h}, {0, -h}, {h - c, -h}, {h, -h + c}, {h, 0}, {h, h - c},
                                  {h - c, h}, {0, h}, {-h + c, h}, {-h, h - c}, {-h, 0}, {-h, -h + c}};
  const double area = loop_area(island);
  const ResampledLoop rs = resample_loop(island, 1.7);
  ASSERT_GE(rs.points.size(), 4u);
  EXPECT_NEAR(loop_area(rs.points), area, kResampleAreaShare * area);
  for (std::size_t i = 0; i < rs.points.size(); ++i)
    EXPECT_LT(distance_to_loop(rs.points[i], island), 1e-12) << "point " << i;
  // The least such count: starting one below it, the search comes to it again.
  double length = 0;
  for (std::size_t i = 0; i < island.size(); ++i) length += (island[(i + 1) % island.size()] - island[i]).norm();
  EXPECT_EQ(resample_loop(island, length / double(rs.points.size() - 1)).points.size(), rs.points.size());
}
