// Label volumes annotated along several axes as sections (io/volume_sections.h),
// on a synthetic tilted volume built in memory.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <functional>

#include "isoloft/core/error.h"
#include "isoloft/io/volume_sections.h"

using namespace isoloft;

namespace {

// 12 x 10 x 8 voxels of 0.5 mm, rotated, labels: a ball of 1 and a box of 2.
Volume labelled_volume() {
  Volume v;
  v.nx = 12, v.ny = 10, v.nz = 8;
  v.spacing = {0.5, 0.5, 0.5};
  v.origin = {10, -5, 3};
  v.direction = (Eigen::AngleAxisd(0.4, Vec3d(1, 2, 3).normalized())).toRotationMatrix();
  v.integer = true;
  v.data.assign(std::size_t(v.nx * v.ny * v.nz), 0);
  for (int k = 0; k < v.nz; ++k)
    for (int j = 0; j < v.ny; ++j)
      for (int i = 0; i < v.nx; ++i) {
        float label = 0;
        if ((Vec3d(i, j, k) - Vec3d(5, 5, 4)).norm() < 3.5) label = 1;
        if (i >= 9 && j <= 3) label = 2;
        v.data[v.index(i, j, k)] = label;
      }
  return v;
}

template <class E>
void expect_message(const std::function<void()>& f, const std::string& want) {
  try {
    f();
    ADD_FAILURE() << "accepted; want: " << want;
  } catch (const E& e) {
    EXPECT_EQ(std::string(e.what()).rfind(want, 0), 0u) << "got:  " << e.what() << "\nwant: " << want;
  }
}

}  // namespace

TEST(VolumeSections, ParsesSliceListsPerAxis) {
  const Volume v = labelled_volume();
  const AnnotatedSlices s = parse_annotated_slices(" k:3,1,3; i:5 ;", v);
  EXPECT_EQ(s.index[0], std::vector<int>({5}));
  EXPECT_TRUE(s.index[1].empty());
  EXPECT_EQ(s.index[2], std::vector<int>({1, 3}));
  EXPECT_EQ(s.count(), 3u);
  auto bad = [&](const std::string& spec, const std::string& problem) {
    expect_message<ParamError>([&] { (void)parse_annotated_slices(spec, v); },
                               "annotated slices '" + spec + "': " + problem);
  };
  bad("x:1", "'x:1' is not AXIS:N,N,... with AXIS one of i, j, k");
  bad("k1", "'k1' is not AXIS:N,N,...");
  bad("k:8", "slice '8' on axis k is not an index in 0..7");
  bad("j:-1", "slice '-1' on axis j is not an index in 0..9");
  bad("k:1,", "slice '' on axis k is not an index");
  bad("k:1;k:2", "axis k given twice");
  bad("", "no slice given");
}

TEST(VolumeSections, SlicesAlongEveryAxisCarryTheirLabelsAndPoses) {
  const Volume v = labelled_volume();
  const AnnotatedSlices slices = parse_annotated_slices("k:4;i:2,10;j:1", v);
  const std::vector<Section> sections = label_volume_sections(v, slices, "dir/labels.nii");
  ASSERT_EQ(sections.size(), 4u);
  const std::vector<std::pair<int, int>> want = {{0, 2}, {0, 10}, {1, 1}, {2, 4}};  // axis i first, then j, k
  const std::vector<std::string> names = {"i=2", "i=10", "j=1", "k=4"};
  for (std::size_t n = 0; n < sections.size(); ++n) {
    const Section& s = sections[n];
    const auto [axis, index] = want[n];
    EXPECT_EQ(s.source, "labels.nii, slice " + names[n]);
    EXPECT_TRUE(s.is_image());
    EXPECT_TRUE(s.contours.empty());
    EXPECT_EQ(s.pixel_size, 0.5);
    EXPECT_TRUE(s.pose.orthonormal(1e-12)) << "section " << n;
    EXPECT_LT((s.pose.normal() - v.direction.col(axis)).norm(), 1e-12) << "section " << n;
    const int ax = (axis + 1) % 3, ay = (axis + 2) % 3;
    const int sizes[3] = {v.nx, v.ny, v.nz};
    ASSERT_EQ(s.labels.width, sizes[ax]) << "section " << n;
    ASSERT_EQ(s.labels.height, sizes[ay]) << "section " << n;
    int inside = 0;
    for (int y = 0; y < s.labels.height; ++y)
      for (int x = 0; x < s.labels.width; ++x) {
        Vec3d ijk;
        ijk[axis] = index, ijk[ax] = x, ijk[ay] = y;
        const Vec3d world = s.pose.to_world(Vec2d(x * s.pixel_size, y * s.pixel_size));
        ASSERT_LT((world - v.to_patient(ijk)).norm(), 1e-9) << "section " << n << " pixel " << x << ", " << y;
        const std::uint32_t label = s.labels.data[s.labels.index(x, y)];
        ASSERT_EQ(label, std::uint32_t(v.at(int(ijk[0]), int(ijk[1]), int(ijk[2]))))
            << "section " << n << " pixel " << x << ", " << y;
        inside += label != 0;
      }
    EXPECT_GT(inside, 0) << "section " << n;
  }
}

TEST(VolumeSections, RefusesWhatASectionCannotHold) {
  Volume v = labelled_volume();
  v.spacing = {0.5, 0.5, 2.0};
  // Axial slices have square pixels; a sagittal one does not.
  EXPECT_EQ(label_volume_sections(v, parse_annotated_slices("k:1", v), "l.nii").size(), 1u);
  expect_message<InputError>([&] { (void)label_volume_sections(v, parse_annotated_slices("k:1;i:5", v), "l.nii"); },
                             "l.nii: slice i=5: its pixels are 0.5 x 2 mm (axes j, k); a section's label image has square pixels");
  Volume f = labelled_volume();
  f.data[f.index(3, 2, 1)] = 1.5f;
  expect_message<InputError>([&] { (void)label_volume_sections(f, parse_annotated_slices("k:1", f), "l.nii"); },
                             "l.nii: voxel (3, 2, 1) holds 1.5, not a label");
  f.data[f.index(3, 2, 1)] = -1.0f;
  expect_message<InputError>([&] { (void)label_volume_sections(f, parse_annotated_slices("j:2", f), "l.nii"); },
                             "l.nii: voxel (3, 2, 1) holds -1, not a label");
  Volume sheared = labelled_volume();
  sheared.direction.col(1) = (sheared.direction.col(1) + 0.01 * sheared.direction.col(0)).normalized();
  expect_message<InputError>([&] { (void)label_volume_sections(sheared, parse_annotated_slices("k:1", sheared), "l.nii"); },
                             "l.nii: voxel axes i and j are not orthogonal");
  expect_message<InputError>([&] { (void)label_volume_sections(v, AnnotatedSlices{}, "l.nii"); }, "l.nii: no annotated slice");
}

TEST(VolumeSections, MaskMarksWholeSlices) {
  const Volume labels = labelled_volume();
  Volume mask = labels;
  std::fill(mask.data.begin(), mask.data.end(), 0.0f);
  auto mark = [&](int axis, int s) {
    for (int k = 0; k < mask.nz; ++k)
      for (int j = 0; j < mask.ny; ++j)
        for (int i = 0; i < mask.nx; ++i)
          if ((axis == 0 ? i : axis == 1 ? j : k) == s) mask.data[mask.index(i, j, k)] = 7;
  };
  mark(2, 2), mark(2, 6), mark(0, 4);
  const AnnotatedSlices s = annotated_slices_from_mask(mask, labels, "mask.nii");
  EXPECT_EQ(s.index[0], std::vector<int>({4}));
  EXPECT_TRUE(s.index[1].empty());  // crossed by the marked slices, not whole
  EXPECT_EQ(s.index[2], std::vector<int>({2, 6}));
  EXPECT_EQ(label_volume_sections(labels, s, "labels.nii").size(), 3u);

  Volume partial = mask;
  partial.data[partial.index(1, 1, 1)] = 1;
  expect_message<InputError>([&] { (void)annotated_slices_from_mask(partial, labels, "mask.nii"); },
                             "mask.nii: annotation mask marks voxel (1, 1, 1) but no whole slice through it");
  Volume moved = mask;
  moved.origin[1] += 0.25;
  expect_message<InputError>([&] { (void)annotated_slices_from_mask(moved, labels, "mask.nii"); },
                             "mask.nii: annotation mask's spacing, origin or direction differ from the labels' on axis j");
  Volume small = mask;
  small.nz = 7;
  expect_message<InputError>([&] { (void)annotated_slices_from_mask(small, labels, "mask.nii"); },
                             "mask.nii: annotation mask of 12 x 10 x 7 voxels, labels of 12 x 10 x 8 voxels: not the same grid");
  Volume none = mask;
  std::fill(none.data.begin(), none.data.end(), 0.0f);
  expect_message<InputError>([&] { (void)annotated_slices_from_mask(none, labels, "mask.nii"); },
                             "mask.nii: annotation mask marks no whole slice");
}
