#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>

#include "io/io_test_util.h"
#include "isoloft/core/error.h"
#include "isoloft/io/csl.h"

using isoloft::CslFile;
using isoloft::CslParams;
using isoloft::InputError;
using isoloft::parse_csl;
using isoloft::read_csl;
using isoloft::Vec2d;
using isoloft::Vec3d;
using isoloft::detail::first_self_contact;
using isoloft::test::TempDir;

namespace {

// Two planes: z = 2 with a square (label 1) and a hole in it, and the tilted
// plane x + y = 2 (A B C D not normalised) with a triangle of label 2.
const char* kTwoPlanes =
    "CSLC\n"
    "2 3\n"
    "\n"
    "1 8 2 0 0 1 -2\n"
    "\n"
    "0 0 2\n4 0 2\n4 4 2\n0 4 2\n"
    "1 1 2\n1 3 2\n3 3 2\n3 1 2\n"
    "\n"
    "4 1 0 1 2 3\n"
    "4h0 1 4 5 6 7\n"
    "2 3 1 2 2 0 -4\n"
    "2 0 0\n0 2 0\n1 1 3\n"
    "3 2 0 1 2\n";

const std::vector<Vec3d> kPlane1 = {{0, 0, 2}, {4, 0, 2}, {4, 4, 2}, {0, 4, 2},
                                    {1, 1, 2}, {1, 3, 2}, {3, 3, 2}, {3, 1, 2}};
const std::vector<Vec3d> kPlane2 = {{2, 0, 0}, {0, 2, 0}, {1, 1, 3}};

// parse_csl must refuse `text` with what() == "t.csl: <problem...>".
void expect_error(const std::string& text, const std::string& problem, const CslParams& params = {}) {
  try {
    (void)parse_csl(text, "t.csl", params);
    ADD_FAILURE() << "accepted:\n" << text;
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("t.csl: " + problem, 0), 0u)
        << "got:  " << e.what() << "\nwant: t.csl: " << problem;
  }
}

// A one-plane file on z = 0 with the given vertex lines and component lines.
std::string one_plane(const std::string& vertices, int nv, const std::string& components, int nc, int labels = 2) {
  return "CSLC\n1 " + std::to_string(labels) + "\n1 " + std::to_string(nv) + " " + std::to_string(nc) +
         " 0 0 1 0\n" + vertices + components;
}

const std::string kSquare = "0 0 0\n1 0 0\n1 1 0\n0 1 0\n";

}  // namespace

TEST(Csl, ReadsPosesContoursLabelsAndHoles) {
  const CslFile f = parse_csl(kTwoPlanes, "dir/two.csl");
  EXPECT_EQ(f.label_count, 3u);
  ASSERT_EQ(f.sections.size(), 2u);
  const std::vector<const std::vector<Vec3d>*> world = {&kPlane1, &kPlane2};
  const std::vector<Vec3d> normals = {Vec3d(0, 0, 1), Vec3d(1, 1, 0).normalized()};
  const std::vector<std::vector<std::vector<int>>> indices = {{{0, 1, 2, 3}, {4, 5, 6, 7}}, {{0, 1, 2}}};
  for (std::size_t s = 0; s < 2; ++s) {
    const auto& sec = f.sections[s];
    EXPECT_EQ(sec.source, "two.csl, plane " + std::to_string(s + 1));
    EXPECT_FALSE(sec.is_image()) << "section " << s;
    EXPECT_TRUE(sec.pose.orthonormal(1e-12)) << "section " << s;
    EXPECT_LT((sec.pose.normal() - normals[s]).norm(), 1e-12) << "section " << s;
    // The origin is on the plane and nearest the world origin.
    EXPECT_LT((sec.pose.origin - sec.pose.origin.dot(normals[s]) * normals[s]).norm(), 1e-12) << "section " << s;
    ASSERT_EQ(sec.contours.size(), indices[s].size()) << "section " << s;
    for (std::size_t c = 0; c < indices[s].size(); ++c) {
      const auto& pts = sec.contours[c].points;
      ASSERT_EQ(pts.size(), indices[s][c].size()) << "section " << s << " contour " << c;
      for (std::size_t k = 0; k < pts.size(); ++k)
        EXPECT_LT((sec.pose.to_world(pts[k]) - (*world[s])[indices[s][c][k]]).norm(), 1e-12)
            << "section " << s << " contour " << c << " point " << k;
    }
  }
  EXPECT_FALSE(f.sections[0].contours[0].hole);
  EXPECT_EQ(f.sections[0].contours[0].label, 1u);
  EXPECT_TRUE(f.sections[0].contours[1].hole);
  EXPECT_EQ(f.sections[0].contours[1].label, 1u);  // the parent's
  EXPECT_EQ(f.sections[1].contours[0].label, 2u);
  // An axial plane keeps the world's axes: u = x, v = y, origin (0, 0, 2).
  EXPECT_EQ(f.sections[0].pose.u, Vec3d(1, 0, 0));
  EXPECT_EQ(f.sections[0].pose.v, Vec3d(0, 1, 0));
  EXPECT_EQ(f.sections[0].pose.origin, Vec3d(0, 0, 2));
}

TEST(Csl, PoseIsRightHandedForEveryNormalSign) {
  for (const Vec3d& n : {Vec3d(0, 0, -3), Vec3d(-1, 0, 0), Vec3d(0, 2, 0), Vec3d(1, -2, 3), Vec3d(-5, 1e-3, 0.5)}) {
    const std::string text = "CSLC\n1 2\n1 0 0 " + std::to_string(n.x()) + " " + std::to_string(n.y()) + " " +
                             std::to_string(n.z()) + " 7\n";
    const auto pose = parse_csl(text, "t.csl").sections.at(0).pose;
    EXPECT_TRUE(pose.orthonormal(1e-12)) << n.transpose();
    EXPECT_LT((pose.u.cross(pose.v) - n.normalized()).norm(), 1e-12) << n.transpose();
    EXPECT_NEAR(pose.height(Vec3d::Zero()) * n.norm(), 7.0, 1e-12) << n.transpose();  // A x + B y + C z + D at 0
  }
}

TEST(Csl, EmptyPlaneIsAllOutside) {
  const CslFile f = parse_csl("CSLC\n2 2\n1 0 0 0 0 1 -1\n2 3 1 0 0 1 0\n" + kSquare.substr(0, 18) + "3 1 0 1 2\n",
                              "t.csl");
  ASSERT_EQ(f.sections.size(), 2u);
  EXPECT_TRUE(f.sections[0].contours.empty());
  EXPECT_FALSE(f.sections[0].is_image());
  EXPECT_EQ(f.sections[1].contours.size(), 1u);
}

TEST(Csl, ToleratesTheLayoutOfRealFiles) {
  // Leading and trailing spaces, CRLF, blank lines anywhere, tabs.
  const CslFile f = parse_csl(
      "CSLC\r\n 1 2 \r\n\r\n1 4 1 0.0 0.0 1.0 -0.5 \r\n\r\n0 0 0.5\r\n1 0 0.5\r\n\t1 1 0.5\r\n0 1 0.5\r\n\r\n4 1 0 1 2 3 \r\n\r\n",
      "t.csl");
  ASSERT_EQ(f.sections.size(), 1u);
  EXPECT_EQ(f.sections[0].contours.at(0).points.size(), 4u);
}

TEST(Csl, HoleLabelledAsOReXWritesItTakesItsParentsLabel) {
  const CslFile f = parse_csl(one_plane(kSquare + "0.2 0.2 0\n0.2 0.8 0\n0.8 0.8 0\n", 7, "4 1 0 1 2 3\n3h0 2 4 5 6\n", 2),
                              "t.csl");
  ASSERT_EQ(f.sections.at(0).contours.size(), 2u);
  EXPECT_TRUE(f.sections[0].contours[1].hole);
  EXPECT_EQ(f.sections[0].contours[1].label, 1u);
}

TEST(Csl, RefusesWhatIsNotCsl) {
  expect_error("", "not a CSL file");
  expect_error("CSL\n1 2\n", "not a CSL file");
  expect_error("CSLC\n", "file ends after CSLC");
  expect_error("CSLC\n1\n", "line 2: expected the plane count and the label count");
  expect_error("CSLC\n0 2\n", "line 2: the file declares no planes");
  expect_error("CSLC\n1 1\n1 0 0 0 0 1 0\n", "line 2: label count 1 (must be at least 2");
  expect_error("CSLC\n1 4294967296\n1 0 0 0 0 1 0\n", "line 2: label count 4294967296 (must be at least 2");
  EXPECT_EQ(parse_csl("CSLC\n1 4294967295\n1 0 0 0 0 1 0\n", "t.csl").label_count, 4294967295u);
}

TEST(Csl, RefusesBadPlanes) {
  expect_error("CSLC\n1 2\n1 0 0 0 0 0 1\n", "plane 1 (line 3): zero normal");
  expect_error("CSLC\n1 2\n1 0 0 0 0 nan 1\n", "plane 1 (line 3): expected a plane header");
  expect_error("CSLC\n1 2\n1 0 0 0 1 1\n", "plane 1 (line 3): expected a plane header");
  expect_error("CSLC\n2 2\n1 0 0 0 0 1 0\n3 0 0 0 0 1 0\n", "plane 2 (line 4): plane index 3 out of order");
  expect_error("CSLC\n1 2\n1 0 0 0 0 1e-300 1e300\n", "plane 1 (line 3): the plane's A B C D give no usable pose");
  expect_error(one_plane(kSquare, 4, "", 0), "plane 1 (line 3): 4 vertices but no component uses them");
}

TEST(Csl, RefusesVerticesOffTheirPlane) {
  // Extent sqrt(2) (the unit square's diagonal): tolerance 1.41e-4.
  expect_error(one_plane("0 0 0\n1 0 0\n1 1 0.001\n0 1 0\n", 4, "4 1 0 1 2 3\n", 1),
               "plane 1 (line 3): vertex 2 lies 0.001 off the plane (tolerance");
  // Within the tolerance: read, and projected onto the plane.
  const CslFile f = parse_csl(one_plane("0 0 0\n1 0 0\n1 1 1e-4\n0 1 0\n", 4, "4 1 0 1 2 3\n", 1), "t.csl");
  EXPECT_EQ(f.sections.at(0).contours.at(0).points.at(2), Vec2d(1, 1));
  // The sign of D matters (rose.csl in OReX's data has it flipped).
  expect_error("CSLC\n1 2\n1 3 1 0 0 1 1\n0 0 1\n1 0 1\n0 1 1\n3 1 0 1 2\n",
               "plane 1 (line 3): vertex 0 lies 2 off the plane");
}

TEST(Csl, RefusesCountsThatLie) {
  // Fewer vertices than declared: a component line is not a vertex.
  expect_error(one_plane(kSquare, 5, "4 1 0 1 2 3\n", 1),
               "plane 1 (line 8): vertex 4 of 5: expected three finite coordinates");
  // More vertices than declared: a vertex line is not a component.
  expect_error(one_plane(kSquare, 3, "4 1 0 1 2 3\n", 1), "plane 1 (line 7): component 0 declares 0 vertices but lists 1 (a vertex line: the plane's vertex count is short?)");
  expect_error(one_plane(kSquare, 4, "4 1 0 1 2 3\n", 2), "plane 1 (line 3): file ends after 1 of 2 components");
  expect_error(one_plane(kSquare, 4, "4 1 0 1 2 3\n4 1 0 1 2 3\n", 1),
               "line 9: text after the last declared plane (1)");
  expect_error(one_plane(kSquare, 4, "4 1 0 1 2\n", 1), "plane 1 (line 8): component 0 declares 4 vertices but lists 3");
  expect_error(one_plane(kSquare, 4, "3 1 0 1 2 3\n", 1), "plane 1 (line 8): component 0 declares 3 vertices but lists 4");
  expect_error(one_plane(kSquare, 4, "4 1 0 1 2 4\n", 1),
               "plane 1 (line 8): component 0: vertex index '4' is not in 0..3");
  expect_error(one_plane(kSquare, 4, "4 1 0 1 2 -1\n", 1),
               "plane 1 (line 8): component 0: vertex index '-1' is not in 0..3");
  expect_error(one_plane("0 0 0\n1 0 0\n", 4, "", 1), "plane 1 (line 3): file ends after 2 of 4 vertices");
  expect_error("CSLC\n2 2\n1 0 0 0 0 1 0\n", "file ends before plane 2 (declared 2 planes)");
  expect_error(one_plane(kSquare, 4, "4 1 0 1 2 3\n", 1) + "garbage\n", "line 9: text after the last declared plane");
  expect_error(one_plane("0 0 0\n1 0 0 7\n1 1 0\n0 1 0\n", 4, "4 1 0 1 2 3\n", 1),
               "plane 1 (line 5): vertex 1 of 4: expected three finite coordinates");
}

TEST(Csl, RefusesSmallComponentsAndBadLabels) {
  expect_error(one_plane(kSquare, 4, "2 1 0 1\n", 1), "plane 1 (line 8): component 0 has 2 vertices (need 3)");
  expect_error(one_plane(kSquare, 4, "4 2 0 1 2 3\n", 1), "plane 1 (line 8): component 0: unknown label 2 (objects are 1..1");
  expect_error(one_plane(kSquare, 4, "4 0 0 1 2 3\n", 1), "plane 1 (line 8): component 0: unknown label 0");
  expect_error(one_plane(kSquare, 4, "4 1.5 0 1 2 3\n", 1), "plane 1 (line 8): component 0: expected a vertex count");
  const std::string hole = kSquare + "0.2 0.2 0\n0.2 0.8 0\n0.8 0.8 0\n";
  expect_error(one_plane(hole, 7, "4 1 0 1 2 3\n3h1 1 4 5 6\n", 2),
               "plane 1 (line 12): component 1: hole in component 1, itself a hole");
  expect_error(one_plane(hole, 7, "4 1 0 1 2 3\n3h5 1 4 5 6\n", 2),
               "plane 1 (line 12): component 1: hole in component 5, which the plane does not have");
  expect_error(one_plane(hole, 7, "4 1 0 1 2 3\n3h0 2 4 5 6\n", 2, 3),
               "plane 1 (line 12): component 1: hole labelled 2 in component 0 of label 1");
  expect_error(one_plane(hole, 7, "4 1 0 1 2 3\n3hx 1 4 5 6\n", 2), "plane 1 (line 12): component 1: expected a vertex count");
}

TEST(Csl, RefusesSelfIntersectingContours) {
  // Bow tie: edge 1-2 crosses edge 3-0.
  expect_error(one_plane("0 0 0\n1 0 0\n0 1 0\n1 1 0\n", 4, "4 1 0 1 2 3\n", 1),
               "plane 1 (line 8): component 0 crosses or touches itself (edge 1-2 meets edge 3-0)");
  // Pinched: vertex 0 visited twice (touching, as in OReX's Abdomen.csl).
  expect_error(one_plane("0 0 0\n1 0 0\n1 1 0\n-1 0 0\n-1 -1 0\n", 5, "6 1 0 1 2 0 3 4\n", 1),
               "plane 1 (line 9): component 0 crosses or touches itself (edge 0-1 meets edge 2-0)");
  // The refusal can be lifted: the contour comes through as drawn.
  CslParams keep;
  keep.refuse_self_intersections = false;
  const CslFile f = parse_csl(one_plane("0 0 0\n1 0 0\n0 1 0\n1 1 0\n", 4, "4 1 0 1 2 3\n", 1), "t.csl", keep);
  EXPECT_EQ(f.sections.at(0).contours.at(0).points.size(), 4u);
}

TEST(Csl, ReadCslNamesTheFile) {
  TempDir dir;
  const std::string path = dir.file("bad.csl");
  isoloft::test::write_text(path, "CSLC\n1 2\n1 0 0 0 0 0 1\n");
  try {
    (void)read_csl(path);
    ADD_FAILURE() << "accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), path + ": plane 1 (line 3): zero normal (A = B = C = 0)");
  }
  EXPECT_THROW((void)read_csl(dir.file("missing.csl")), InputError);
  const std::string good = dir.file("two.csl");
  isoloft::test::write_text(good, kTwoPlanes);
  EXPECT_EQ(read_csl(good).sections.size(), 2u);
}

TEST(SelfContact, FindsCrossingsTouchesAndFolds) {
  EXPECT_FALSE(first_self_contact({{0, 0}, {1, 0}, {1, 1}, {0, 1}}));
  EXPECT_FALSE(first_self_contact({{0, 0}, {2, 0}, {1, 1}}));
  // Concave but simple: an L.
  EXPECT_FALSE(first_self_contact({{0, 0}, {2, 0}, {2, 1}, {1, 1}, {1, 2}, {0, 2}}));
  using Pair = std::pair<std::size_t, std::size_t>;
  EXPECT_EQ(first_self_contact({{0, 0}, {1, 0}, {0, 1}, {1, 1}}), Pair(1, 3));
  // A vertex on a non-neighbouring edge.
  EXPECT_EQ(first_self_contact({{0, 0}, {2, 0}, {2, 2}, {1, 0}, {0, 2}}), Pair(0, 2));
  // A spike folding back along its own line.
  EXPECT_EQ(first_self_contact({{0, 0}, {2, 0}, {3, 0}, {2.5, 0}, {2, 2}}), Pair(1, 2));
  // A flat triangle.
  EXPECT_TRUE(first_self_contact({{0, 0}, {1, 0}, {2, 0}}));
  // A repeated point (zero-length edge) touches its neighbours' neighbours.
  EXPECT_TRUE(first_self_contact({{0, 0}, {1, 0}, {1, 0}, {1, 1}, {0, 1}}));
}

// Star-shaped polygons (distinct angles, positive radii) are simple; swapping
// two far-apart vertices of a convex one makes it cross itself.
RC_GTEST_PROP(SelfContact, StarShapedIsSimpleAndSwappedConvexIsNot, ()) {
  const int n = *rc::gen::inRange(3, 40);
  std::vector<Vec2d> star, convex;
  for (int k = 0; k < n; ++k) {
    const double a = 2 * M_PI * (k + 0.1 + 0.8 * *rc::gen::inRange(0, 1000) / 1000.0) / n;
    const double r = 0.2 + *rc::gen::inRange(0, 1000) / 1000.0;
    star.emplace_back(r * std::cos(a), r * std::sin(a));
    convex.emplace_back(std::cos(a), std::sin(a));
  }
  RC_ASSERT(!first_self_contact(star));
  RC_ASSERT(!first_self_contact(convex));
  if (n >= 5) {
    std::swap(convex[0], convex[2]);
    RC_ASSERT(first_self_contact(convex).has_value());
  }
}

// OReX's own data (the mirror fetched for issue 35, when present): every file
// reads, except those whose defects the reader exists to catch. Not copied
// into the repository: the OReX repository states no licence.
TEST(Csl, ReadsOReXData) {
  const std::string repo = "/work/.mirror/haimsaw+OReX/repo";
  if (!std::filesystem::exists(repo)) GTEST_SKIP() << "no OReX mirror at " << repo;
  TempDir dir;
  // name -> the start of the expected problem ("" for accepted)
  const std::map<std::string, std::string> expected = {
      {"csl_with_ref/eight_15.csl", ""},
      {"csl_with_ref/eight_20.csl", ""},
      {"csl_with_ref/balloondog.csl", ""},
      {"csl_with_ref/balloondog_box.csl", ""},
      {"csl_with_ref/hand.csl", ""},
      {"csl_with_ref/hand_ok.csl", ""},
      {"csl_with_ref/Elephant.csl", ""},
      {"csl_with_ref/armadillo.csl", ""},
      {"csl_with_ref/lamp004_fixed.csl", "plane 1 (line 932): component 0 crosses or touches itself (edge 175-176 meets edge 182-183)"},
      {"csl_with_ref/lamp004_fixed_simplified.csl", "plane 1 "},
      {"csl_without_ref/Horsers.csl", ""},
      {"csl_without_ref/rose.csl", "plane 1 (line 4): vertex 0 lies 1.3986"},
      {"csl_without_ref/Skull-20.csl", ""},
      {"csl_without_ref/Heart-simplified.csl", ""},
      {"csl_without_ref/rocker-arm.csl", ""},
      {"csl_without_ref/Vetebrae.csl", "plane 20 (line 6920): component 6 crosses or touches itself"},
      {"csl_without_ref/Abdomen.csl", "plane 7 (line 2776): component 3 crosses or touches itself"},
  };
  for (const auto& [name, problem] : expected) {
    const std::string path = dir.file(std::filesystem::path(name).filename().string());
    const std::string cmd = "git -C " + repo + " show HEAD:Data/" + name + " > " + path + " 2>/dev/null";
    ASSERT_EQ(std::system(cmd.c_str()), 0) << name;
    try {
      const CslFile f = read_csl(path);
      EXPECT_EQ(problem, "") << name << " read";
      EXPECT_GE(f.sections.size(), 2u) << name;
      for (std::size_t s = 0; s < f.sections.size(); ++s) EXPECT_FALSE(f.sections[s].contours.empty()) << name << " " << s;
    } catch (const InputError& e) {
      EXPECT_NE(problem, "") << name << ": " << e.what();
      if (!problem.empty()) {
        EXPECT_EQ(e.problem.rfind(problem, 0), 0u) << name << ": " << e.what();
      }
    }
  }
  // With self-intersections let through, lamp004 reads: 34 planes.
  CslParams keep;
  keep.refuse_self_intersections = false;
  EXPECT_EQ(read_csl(dir.file("lamp004_fixed.csl"), keep).sections.size(), 34u);
}
