// RT ROIs as world-space sections (io/rtstruct_sections.h): synthetic ROIs
// on tilted, sagittal and mixed planes built in memory, and every ROI of the
// real breast set (axial) through the same function.
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "isoloft/core/error.h"
#include "isoloft/io/plane_fit.h"
#include "isoloft/io/rtstruct.h"
#include "isoloft/io/rtstruct_sections.h"

using namespace isoloft;

namespace {

// An orthonormal frame (a, b) spanning the plane of unit normal n.
std::pair<Vec3d, Vec3d> frame(const Vec3d& n) {
  const Vec3d a = n.unitOrthogonal();
  return {a, n.cross(a)};
}

// A circle of radius r about `centre` on the plane of unit normal n, m points.
std::vector<Vec3d> circle(const Vec3d& centre, const Vec3d& n, double r, int m = 24) {
  const auto [a, b] = frame(n);
  std::vector<Vec3d> out;
  for (int k = 0; k < m; ++k) {
    const double t = 2 * M_PI * k / m;
    out.push_back(centre + r * (std::cos(t) * a + std::sin(t) * b));
  }
  return out;
}

RtRoi roi_of(const std::vector<std::vector<Vec3d>>& contours, const std::string& name = "Tilted") {
  RtRoi roi;
  roi.number = 7;
  roi.name = name;
  for (const auto& c : contours) roi.contours.push_back(RtContour{"CLOSED_PLANAR", c});
  return roi;
}

// Every contour point of `roi` is a point of some section's contours, within `tol` mm.
void expect_points_kept(const RtRoi& roi, const std::vector<Section>& sections, double tol) {
  for (std::size_t k = 0; k < roi.contours.size(); ++k)
    for (std::size_t i = 0; i < roi.contours[k].points.size(); ++i) {
      const Vec3d& p = roi.contours[k].points[i];
      double best = INFINITY;
      for (const Section& s : sections) {
        if (std::abs(s.pose.height(p)) > tol) continue;  // not its plane
        for (const auto& c : s.contours)
          for (const Vec2d& q : c.points) best = std::min(best, (s.pose.to_world(q) - p).norm());
      }
      EXPECT_LE(best, tol) << "contour " << k << " point " << i;
    }
}

void expect_error(const RtRoi& roi, const std::string& problem) {
  std::vector<std::string> warnings;
  try {
    (void)roi_sections(roi, "rs.dcm", warnings);
    ADD_FAILURE() << "accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("rs.dcm: " + problem, 0), 0u) << "got:  " << e.what() << "\nwant: " << problem;
  }
}

}  // namespace

TEST(RtSections, TiltedStackIsOneSectionPerPlane) {
  const Vec3d n = Vec3d(0.3, -0.2, 1).normalized();
  std::vector<std::vector<Vec3d>> contours;
  for (int k = 0; k < 6; ++k) contours.push_back(circle(Vec3d(10, -20, 5) + 3.0 * k * n, n, 8 + k));
  const RtRoi roi = roi_of(contours);
  std::vector<std::string> warnings;
  const std::vector<Section> sections = roi_sections(roi, "dir/rs.dcm", warnings);
  EXPECT_TRUE(warnings.empty());
  ASSERT_EQ(sections.size(), 6u);
  for (std::size_t k = 0; k < 6; ++k) {
    const Section& s = sections[k];
    EXPECT_EQ(s.source, "rs.dcm, ROI 'Tilted', plane " + std::to_string(k + 1));
    EXPECT_TRUE(s.pose.orthonormal(1e-12)) << "section " << k;
    EXPECT_LT((s.pose.normal() - n).norm(), 1e-9) << "section " << k;  // largest component (z) positive
    EXPECT_NEAR(s.pose.height(Vec3d(10, -20, 5) + 3.0 * double(k) * n), 0, 1e-9) << "section " << k;
    ASSERT_EQ(s.contours.size(), 1u) << "section " << k;
    EXPECT_EQ(s.contours[0].label, 1u);
    EXPECT_FALSE(s.contours[0].hole);
    EXPECT_EQ(s.contours[0].points.size(), 24u) << "section " << k;
  }
  expect_points_kept(roi, sections, 1e-9);
}

TEST(RtSections, MixedOrientationsAndCoplanarContours) {
  // Axial z = 4 with an island and a hole (one section), sagittal x = -3, and
  // an oblique plane; a second contour on the oblique plane far from the first.
  const Vec3d obl = Vec3d(1, 1, 1).normalized();
  const RtRoi roi = roi_of({circle({0, 0, 4}, Vec3d::UnitZ(), 10), circle({-3, 0, 0}, Vec3d::UnitX(), 6),
                            circle({1, 1, 4}, Vec3d::UnitZ(), 3), circle({5, 5, 5}, obl, 4),
                            circle(Vec3d(5, 5, 5) + 20 * frame(obl).first, obl, 2)});
  std::vector<std::string> warnings;
  const std::vector<Section> sections = roi_sections(roi, "rs.dcm", warnings);
  ASSERT_EQ(sections.size(), 3u);
  const std::vector<Vec3d> normals = {Vec3d::UnitZ(), Vec3d::UnitX(), obl};
  const std::vector<std::size_t> counts = {2, 1, 2};
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_LT((sections[k].pose.normal() - normals[k]).norm(), 1e-9) << "section " << k;
    EXPECT_EQ(sections[k].contours.size(), counts[k]) << "section " << k;
  }
  // Axial planes keep the patient axes.
  EXPECT_LT((sections[0].pose.u - Vec3d::UnitX()).norm(), 1e-12);
  EXPECT_LT((sections[0].pose.v - Vec3d::UnitY()).norm(), 1e-12);
  EXPECT_LT((sections[0].pose.origin - Vec3d(0, 0, 4)).norm(), 1e-9);
  expect_points_kept(roi, sections, 1e-9);
}

TEST(RtSections, RoundedCoordinatesStayOnTheirPlane) {
  // Coordinates rounded to 0.01 mm (coarse planning-system strings) on a
  // steep plane: within the tolerance, and planes 1 mm apart stay apart.
  const Vec3d n = Vec3d(0.6, 0.7, 0.2).normalized();
  std::vector<std::vector<Vec3d>> contours;
  for (int k = 0; k < 3; ++k) {
    auto c = circle(Vec3d(100, -50, 30) + 1.0 * k * n, n, 15, 60);
    for (Vec3d& p : c)
      for (int d = 0; d < 3; ++d) p[d] = std::round(p[d] * 100) / 100;
    contours.push_back(c);
  }
  const RtRoi roi = roi_of(contours);
  std::vector<std::string> warnings;
  const std::vector<Section> sections = roi_sections(roi, "rs.dcm", warnings);
  ASSERT_EQ(sections.size(), 3u);
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_LT((sections[k].pose.normal() - n).norm(), 1e-3) << "section " << k;
    EXPECT_LE(fit_plane(contours[k]).max_residual, 0.0087) << "section " << k;  // the rounding bound
  }
  expect_points_kept(roi, sections, kRtOffPlaneToleranceMm);
}

TEST(RtSections, NonPlanarContoursAreErrorsNamingRoiAndContour) {
  // A saddle: a circle of 10 mm whose z rises and falls by 0.5 mm.
  auto saddle = circle({0, 0, 0}, Vec3d::UnitZ(), 10);
  for (std::size_t i = 0; i < saddle.size(); ++i) saddle[i].z() += 0.5 * std::sin(2 * 2 * M_PI * double(i) / 24);
  expect_error(roi_of({circle({0, 0, 5}, Vec3d::UnitZ(), 5), saddle}), "ROI 'Tilted' contour 1: not planar (its points are up to 0.5");
  // Just beyond the tolerance on a tilted plane.
  auto bent = circle({0, 0, 0}, Vec3d(1, 2, 3).normalized(), 10);
  bent[0] += 0.05 * Vec3d(1, 2, 3).normalized();
  expect_error(roi_of({bent}, "Bent"), "ROI 'Bent' contour 0: not planar");
}

TEST(RtSections, CollinearContoursOffEveryPlaneAreSkippedWithAWarning) {
  std::vector<std::string> warnings;
  const auto sections = roi_sections(roi_of({{{0, 0, 0}, {1, 1, 1}, {2, 2, 2}, {5, 5, 5}},
                                             circle({0, 0, 1}, Vec3d::UnitZ(), 4)}),
                                     "rs.dcm", warnings);
  EXPECT_EQ(sections.size(), 1u);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0], "rs.dcm: ROI 'Tilted': 1 contour(s) too narrow to give a plane (within 0.02 mm RMS of a line) and on no plane of the others skipped");
  expect_error(roi_of({{{0, 0, 0}, {1, 1, 1}, {2, 2, 2}}}), "ROI 'Tilted' has no closed planar contour that encloses an area");
  // A narrow contour on the plane of another joins it.
  const auto joined = roi_sections(roi_of({{{0, 0, 1}, {1, 0.001, 1}, {2, 0, 1}}, circle({0, 0, 1}, Vec3d::UnitZ(), 4)}),
                                   "rs.dcm", warnings);
  ASSERT_EQ(joined.size(), 1u);
  EXPECT_EQ(joined[0].contours.size(), 2u);
}

// A small contour listed first whose own fit is tilted by rounding joins the
// plane of the large contour it lies on.
TEST(RtSections, SmallContourJoinsThePlaneItLiesOn) {
  const std::vector<Vec3d> speck = {{0, 0, 5}, {0.3, 0, 5.01}, {0.3, 0.3, 5}, {0, 0.3, 4.995}};
  std::vector<std::string> warnings;
  const auto sections = roi_sections(roi_of({speck, circle({0, 0, 5}, Vec3d::UnitZ(), 20)}), "rs.dcm", warnings);
  ASSERT_EQ(sections.size(), 1u);
  EXPECT_EQ(sections[0].contours.size(), 2u);
  EXPECT_LT((sections[0].pose.normal() - Vec3d::UnitZ()).norm(), 1e-3);
  EXPECT_EQ(sections[0].contours[0].points.size(), 4u);  // file order kept
}

TEST(RtSections, SkipsWhatIsNotAClosedContourAndSplitsKeyholes) {
  RtRoi roi = roi_of({circle({0, 0, 0}, Vec3d(0, 1, 1).normalized(), 10)});
  roi.contours.push_back(RtContour{"POINT", {{1, 2, 3}}});
  roi.contours.push_back(RtContour{"OPEN_PLANAR", circle({0, 0, 0}, Vec3d::UnitZ(), 3)});
  roi.contours.push_back(RtContour{"CLOSED_PLANAR", {{0, 0, 0}, {1, 0, 0}}});
  // A keyhole on the tilted plane: the outer square and an inner one joined by a cut.
  const auto [a, b] = frame(Vec3d(0, 1, 1).normalized());
  auto at = [&](double s, double t) -> Vec3d { return Vec3d(40, 0, 0) + s * a + t * b; };
  const std::vector<Vec3d> outer = {at(-5, -5), at(5, -5), at(5, 5), at(-5, 5)};
  const std::vector<Vec3d> inner = {at(-2, -2), at(2, -2), at(2, 2), at(-2, 2)};
  std::vector<Vec3d> key{outer[0], inner[0], inner[3], inner[2], inner[1], inner[0]};
  key.insert(key.end(), outer.begin(), outer.end());
  roi.contours.push_back(RtContour{"CLOSED_PLANAR", key});
  std::vector<std::string> warnings;
  const std::vector<Section> sections = roi_sections(roi, "rs.dcm", warnings);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0], "rs.dcm: ROI 'Tilted': 3 contour(s) not CLOSED_PLANAR with 3 or more points skipped");
  ASSERT_EQ(sections.size(), 1u);  // the keyhole lies on the circle's plane
  ASSERT_EQ(sections[0].contours.size(), 3u);
  EXPECT_EQ(sections[0].contours[1].points.size() + sections[0].contours[2].points.size(), 8u);
  RtRoi none;
  none.name = "Empty";
  none.contours.push_back(RtContour{"POINT", {{1, 2, 3}}});
  expect_error(none, "ROI 'Empty' has no closed planar contour that encloses an area");
}

// The real breast set, every ROI with closed contours: axial sections, one
// per distinct contour z, every vertex kept.
TEST(RtSections, RealAxialSetGivesAxialSections) {
  const std::string path = std::string(ISOLOFT_SOURCE_DIR) + "/data/rtstruct/rtss.dcm";
  const RtStructureSet set = read_rtstruct(path);
  int rois = 0;
  for (const RtRoi& roi : set.rois) {
    if (roi.closed_contours() == 0 || roi.number_shared) continue;
    ++rois;
    std::vector<std::string> warnings;
    const std::vector<Section> sections = roi_sections(roi, path, warnings);
    std::set<double> z;
    for (const RtContour& c : roi.contours)
      if (c.type == "CLOSED_PLANAR" && c.points.size() >= 3) z.insert(c.points.front().z());
    EXPECT_EQ(sections.size(), z.size()) << roi.name;
    for (std::size_t k = 0; k < sections.size(); ++k) {
      EXPECT_LT((sections[k].pose.normal() - Vec3d::UnitZ()).norm(), 1e-9) << roi.name << " section " << k;
      EXPECT_LT((sections[k].pose.u - Vec3d::UnitX()).norm(), 1e-9) << roi.name << " section " << k;
    }
    expect_points_kept(roi, sections, 1e-6);
  }
  EXPECT_GE(rois, 5);
}
