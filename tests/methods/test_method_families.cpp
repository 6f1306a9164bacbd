// @file tests/methods/test_method_families.cpp
// @brief The method families behind one seam (methods/method.h): every
// registered method is of exactly one family, and reconstruct() runs a family
// of its own (field3d) for a polygon stack as for the same slices handed over
// as parallel sections.
#include <gtest/gtest.h>

#include "isoloft/core/error.h"
#include "isoloft/methods/method.h"
#include "isoloft/pipeline.h"

namespace isoloft {
namespace {

TEST(MethodFamilies, EveryMethodHasExactlyOneFamily) {
  for (const MethodSpec& m : methods()) {
    EXPECT_NE(bool(m.slice_field), bool(m.reconstruct)) << "method " << m.name;
    // Reading sections at any angle needs a family of its own: the columns one streams parallel slices.
    if (m.reads_sections) EXPECT_TRUE(m.reconstruct) << "method " << m.name;
  }
  EXPECT_EQ(section_method_names(), "field3d");
}

// A square of side 2 * half around (c, c), counter-clockwise.
Polygon square(double c, double half) {
  return Polygon{{{c - half, c - half}, {c + half, c - half}, {c + half, c + half}, {c - half, c + half}}};
}

TEST(MethodFamilies, OwnFamilyRunsThePolygonStackAsParallelSections) {
  SliceStack st;
  st.kind = InputKind::Polylines;
  st.width = st.height = 40;
  std::vector<Section> sections;
  for (int k = 0; k < 5; ++k) {
    Slice s;
    s.z = 4.0 * k;
    s.source = "slice " + std::to_string(k);
    s.polygons.push_back(square(20, 6 + k % 2));
    Section sec;
    sec.pose.origin = Vec3d(0, 0, s.z);
    sec.source = s.source;
    sec.contours.push_back({s.polygons[0].points, 1, false});
    sections.push_back(sec);
    st.slices.push_back(std::move(s));
  }
  ReconstructParams p = method_defaults(Method::Field3d);
  p.field3d.resolution = 24;  // small grid: the test compares two runs, not accuracy
  const ReconstructResult from_stack = reconstruct(st, p);
  const SliceStack none;
  const ReconstructResult from_sections = reconstruct(MethodInput{none, sections, 1}, p);
  ASSERT_EQ(from_stack.objects.size(), 1u);
  ASSERT_EQ(from_sections.objects.size(), 1u);
  const TriMesh& a = from_stack.objects[0].mesh;
  const TriMesh& b = from_sections.objects[0].mesh;
  ASSERT_FALSE(a.empty());
  EXPECT_TRUE(from_stack.objects[0].check.closed);
  EXPECT_EQ(from_stack.objects[0].slices_with_contours, 5);
  ASSERT_EQ(a.vertices.size(), b.vertices.size());
  ASSERT_EQ(a.triangles.size(), b.triangles.size());
  for (std::size_t i = 0; i < a.vertices.size(); ++i) EXPECT_EQ(a.vertices[i], b.vertices[i]) << "vertex " << i;
  for (std::size_t i = 0; i < a.triangles.size(); ++i) EXPECT_EQ(a.triangles[i], b.triangles[i]) << "triangle " << i;
}

// Contour images (1-pixel curves) are refused; masks and labels are read
// (tests/field3d/test_image_sections.cpp).
TEST(MethodFamilies, OwnFamilyRefusesContourImageStacks) {
  SliceStack st;
  st.kind = InputKind::Contours;
  st.width = st.height = 8;
  EXPECT_THROW(reconstruct(st, method_defaults(Method::Field3d)), ParamError);
}

}  // namespace
}  // namespace isoloft
