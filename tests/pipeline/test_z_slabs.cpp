// Z slabs (ReconstructOptions::z_slab): every slab's mesh joined by
// join_slabs() is the one-piece run's mesh, triangle for triangle, for one
// object and for a label partition, with empty slices with and without
// non-empty neighbours; the runs that cannot be cut are refused.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "isoloft/mesh/slab_join.h"
#include "isoloft/pipeline.h"
#include "isoloft/synth/synth.h"
#include "pipeline/split_disc.h"

namespace isoloft {
namespace {

using Triangle = std::array<float, 9>;

// The triangles by their corners' positions, each starting at its smallest
// corner (orientation kept), sorted: equal for the same surface whatever
// the vertex numbering.
std::vector<Triangle> triangles(const TriMesh& m) {
  std::vector<Triangle> out;
  for (const auto& t : m.triangles) {
    std::array<std::array<float, 3>, 3> c;
    for (int i = 0; i < 3; ++i) {
      const Vec3f& v = m.vertices[std::size_t(t[std::size_t(i)])];
      c[std::size_t(i)] = {v.x(), v.y(), v.z()};
    }
    std::rotate(c.begin(), std::min_element(c.begin(), c.end()), c.end());
    Triangle tr;
    for (int i = 0; i < 9; ++i) tr[std::size_t(i)] = c[std::size_t(i / 3)][std::size_t(i % 3)];
    out.push_back(tr);
  }
  std::sort(out.begin(), out.end());
  return out;
}

void expect_same_triangles(const TriMesh& got, const TriMesh& want, const std::string& what) {
  const std::vector<Triangle> a = triangles(got), b = triangles(want);
  ASSERT_EQ(a.size(), b.size()) << what;
  for (std::size_t i = 0; i < a.size(); ++i)
    ASSERT_EQ(a[i], b[i]) << what << ": sorted triangle " << i << " of " << a.size() << " differs";
}

ReconstructResult run(const SliceStack& st, const ReconstructParams& p, ZSlab slab = {}) {
  ReconstructOptions o;
  o.z_slab = slab;
  return reconstruct(st, p, o);
}

// Each object of the one-piece run against its slabs joined, for every
// slab count in `counts`.
void expect_slabs_join_to_the_whole(const SliceStack& st, const ReconstructParams& p, const std::string& what,
                                    std::initializer_list<std::size_t> counts) {
  const ReconstructResult whole = run(st, p);
  ASSERT_FALSE(whole.objects.empty()) << what;
  for (const std::size_t count : counts) {
    std::vector<ReconstructResult> parts;
    for (std::size_t i = 0; i < count; ++i) parts.push_back(run(st, p, {i, count}));
    for (std::size_t o = 0; o < whole.objects.size(); ++o) {
      const ObjectResult& w = whole.objects[o];
      const std::string name = what + ", " + std::to_string(count) + " slabs, label " + std::to_string(w.label);
      std::vector<TriMesh> meshes;
      for (const ReconstructResult& r : parts) {
        ASSERT_EQ(r.objects.size(), whole.objects.size()) << name;
        ASSERT_EQ(r.objects[o].label, w.label) << name;
        meshes.push_back(r.objects[o].mesh);
      }
      const SlabJoinResult j = join_slabs(meshes);
      EXPECT_EQ(j.unmatched, 0) << name;
      EXPECT_TRUE(j.check.closed && j.check.manifold && j.check.oriented) << name;
      EXPECT_EQ(j.mesh.vertices.size(), w.mesh.vertices.size()) << name;
      expect_same_triangles(j.mesh, w.mesh, name);
    }
  }
}

ReconstructParams undecimated() {
  ReconstructParams p;
  p.decimate.max_error = 0;
  return p;
}

TEST(ZSlabs, JoinedSlabsAreTheOnePieceMesh) {
  SynthParams sp;
  sp.size = 32;
  sp.z_spacing = 1.25;
  SliceStack st = synthesize(*make_default_shape("sphere", sp.size), sp).stack;
  const std::size_t n = st.slices.size();
  ASSERT_GE(n, 16u);
  // Empty: two at the bottom, three in the middle and three at the top
  // (slices 11, n - 2 and n - 1 have no non-empty neighbour: under
  // isolated_empty lowest they take the lowest value of every field, the
  // bottom's small contours' included, so an upper slab computes the fields
  // below it too; the other rules read fields within a few slices).
  for (const std::size_t k : {std::size_t(0), std::size_t(1), std::size_t(10), std::size_t(11), std::size_t(12),
                              n - 3, n - 2, n - 1})
    std::fill(st.slices[k].image.data.begin(), st.slices[k].image.data.end(), 0u);
  ReconstructParams p = undecimated();
  expect_slabs_join_to_the_whole(st, p, "isoloft", {2, 3});
  for (const auto& [rule, name] : kIsolatedEmptyNames) {
    if (rule == p.interp.isolated_empty) continue;
    ReconstructParams q = p;
    q.interp.isolated_empty = rule;
    expect_slabs_join_to_the_whole(st, q, std::string("isoloft, isolated_empty ") + name, {3});
  }
  p.method = Method::Marker2006;  // planes off the slices: the cuts fall between them
  expect_slabs_join_to_the_whole(st, p, "marker2006", {3});
}

TEST(ZSlabs, JoinedSlabsAreTheOnePieceMeshForALabelPartition) {
  // Labels 1 and 2 split a disc along a line that turns by slice; label 3,
  // a small disc beside it, only in slices 2-4 (empty elsewhere: isolated).
  SliceStack st = test::split_disc({48, 14.0, 14, 4.0, M_PI / 9});
  for (std::size_t k = 2; k <= 4; ++k)
    for (int y = 0; y < st.height; ++y)
      for (int x = 0; x < st.width; ++x)
        if (std::hypot(x - 42.0, y - 42.0) < 4.0) st.slices[k].image(x, y) = 3;
  expect_slabs_join_to_the_whole(st, undecimated(), "partition", {3});
}

TEST(ZSlabs, RefusedWhereASlabCannotBeExact) {
  SynthParams sp;
  sp.size = 24;
  sp.z_spacing = 4.0;
  const SliceStack st = synthesize(*make_default_shape("sphere", sp.size), sp).stack;
  const auto refused = [&](const ReconstructParams& p, ZSlab slab, const std::string& says) {
    try {
      run(st, p, slab);
      ADD_FAILURE() << "slab " << slab.index << " of " << slab.count << " ran; want an error saying " << says;
    } catch (const ParamError& e) {
      EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
    }
  };
  ReconstructParams p = undecimated();
  refused(p, {3, 3}, "no such slab");
  refused(p, {0, 1000}, "two cuts fall on one plane");
  ReconstructParams natural = p;
  natural.interp.spline = SplineKind::Natural;
  refused(natural, {0, 2}, "finite tangent reach");
  ReconstructParams decimated = p;
  decimated.decimate.max_error = 0.1;
  refused(decimated, {0, 2}, "no decimation");
  ReconstructParams field3d = p;
  field3d.method = Method::Field3d;
  refused(field3d, {0, 2}, "column methods only");
}

TEST(ZSlabs, AJoinWithoutPartnersStaysOpen) {
  // Two unit squares' halves: the lower part's top cut at z = 1 meets an
  // upper part cut elsewhere (z = 2): nothing welds, the result is open.
  TriMesh lower, upper;
  lower.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 0, 1}, {1, 0, 1}};
  lower.triangles = {{0, 1, 2}, {1, 3, 2}};
  upper.vertices = {{0, 0, 2}, {1, 0, 2}, {0, 0, 3}, {1, 0, 3}};
  upper.triangles = {{0, 1, 2}, {1, 3, 2}};
  const SlabJoinResult j = join_slabs({lower, upper});
  EXPECT_EQ(j.welded, 0);
  EXPECT_GT(j.unmatched, 0);
  EXPECT_FALSE(j.check.closed);
  // The same parts meeting at z = 1: the cut's two vertices weld.
  for (auto& v : upper.vertices) v.z() -= 1;
  const SlabJoinResult k = join_slabs({lower, upper});
  EXPECT_EQ(k.welded, 2);
  EXPECT_EQ(k.mesh.vertices.size(), 6u);
}

}  // namespace
}  // namespace isoloft
