// Labels as a partition (ReconstructParams::label_partition): a disc split
// by a line that turns from slice to slice, two labels touching along it.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <set>
#include <string>

#include "isoloft/pipeline.h"
#include "pipeline/split_disc.h"

namespace isoloft {
namespace {

constexpr int kSize = 64;
constexpr double kCentre = 31.5, kRadius = 22.0, kSpacing = 6.0;
constexpr int kSlices = 5;

SliceStack split_disc() { return test::split_disc({kSize, kRadius, kSlices, kSpacing, M_PI / 6}); }

// Per sampled height, how many labels claim each pixel (field > 0).
struct Claims {
  std::map<double, Grid2<int>> count;
};

Claims claims(const SliceStack& st, const ReconstructParams& p, const std::vector<double>& heights,
              ReconstructResult* out = nullptr) {
  Claims c;
  ReconstructOptions o;
  o.sample_z = heights;
  o.on_sample = [&](std::uint32_t, const Grid2f& f, const PixelBox& b, double z) {
    auto [it, added] = c.count.try_emplace(z, Grid2<int>(kSize, kSize, 0));
    for (int y = 0; y < b.height(); ++y)
      for (int x = 0; x < b.width(); ++x) it->second(x + b.x0, y + b.y0) += f(x, y) > 0;
  };
  ReconstructResult r = reconstruct(st, p, o);
  if (out) *out = std::move(r);
  return c;
}

// Pixels this far inside the disc's edge belong to the union at every height
// (the union's cross-section is the disc on every slice; its interpolation
// keeps it within a pixel of it).
constexpr double kUnionEdgeMargin = 2.0;

TEST(Partition, EveryPixelInsideTheUnionHasExactlyOneLabel) {
  const SliceStack st = split_disc();
  const std::vector<double> mid{0.5 * kSpacing, 1.5 * kSpacing, 2.5 * kSpacing, 3.5 * kSpacing};
  long unclaimed_partition = 0, twice_partition = 0, unclaimed_independent = 0;
  for (const bool partition : {true, false}) {
    ReconstructParams p;
    p.label_partition = partition;
    const Claims c = claims(st, p, mid);
    ASSERT_EQ(c.count.size(), mid.size());
    for (const auto& [z, n] : c.count)
      for (int y = 0; y < kSize; ++y)
        for (int x = 0; x < kSize; ++x) {
          if (std::hypot(x - kCentre, y - kCentre) > kRadius - kUnionEdgeMargin) continue;
          if (partition) {
            unclaimed_partition += n(x, y) == 0;
            twice_partition += n(x, y) > 1;
            EXPECT_EQ(n(x, y), 1) << "pixel (" << x << ", " << y << ") at z " << z;
          } else {
            unclaimed_independent += n(x, y) == 0;
          }
        }
  }
  EXPECT_EQ(unclaimed_partition, 0);
  EXPECT_EQ(twice_partition, 0);
  // The independent fits pull apart along the moving split: the case the partition exists for.
  EXPECT_GT(unclaimed_independent, 0);
}

// Vertices of a shared boundary coincide: the two labels' Marching Cubes
// interpolate psi_1 = -psi_2 on the same edges. Float rounding of the two
// subtractions leaves this much.
constexpr double kSharedVertexTol = 1e-3;  // px

TEST(Partition, NeighboursMeshesShareTheirBoundaryVertices) {
  const SliceStack st = split_disc();
  ReconstructParams p;
  ReconstructResult r;
  (void)claims(st, p, {}, &r);
  ASSERT_EQ(r.objects.size(), 2u);
  for (const ObjectResult& o : r.objects) {
    EXPECT_TRUE(o.check.closed && o.check.manifold && o.check.oriented) << "label " << o.label;
  }
  const auto key = [](const Vec3f& v) {
    return std::array<long, 3>{std::lround(v.x() / kSharedVertexTol), std::lround(v.y() / kSharedVertexTol),
                               std::lround(v.z() / kSharedVertexTol)};
  };
  std::set<std::array<long, 3>> second;
  for (const Vec3f& v : r.objects[1].mesh.vertices)
    for (long dx : {-1, 0, 1})
      for (long dy : {-1, 0, 1})
        for (long dz : {-1, 0, 1}) {
          auto k = key(v);
          second.insert({k[0] + dx, k[1] + dy, k[2] + dz});
        }
  // Label 1's vertices on the split (well inside the disc, within the slice range).
  long shared = 0, missing = 0;
  const TriMesh& m = r.objects[0].mesh;
  for (std::size_t i = 0; i < m.vertices.size(); ++i) {
    const Vec3f& v = m.vertices[i];
    if (std::hypot(v.x() - kCentre, v.y() - kCentre) > kRadius - kUnionEdgeMargin) continue;
    if (v.z() < 0 || v.z() > kSpacing * (kSlices - 1)) continue;
    ++shared;
    if (!second.count(key(v))) {
      ++missing;
      ADD_FAILURE() << "label 1 vertex " << i << " (" << v.x() << ", " << v.y() << ", " << v.z()
                    << ") has no label 2 vertex within " << kSharedVertexTol << " px";
      if (missing > 5) break;
    }
  }
  EXPECT_GT(shared, 100);
  EXPECT_EQ(missing, 0);
}

// A label that meets only the background keeps its own surface.
TEST(Partition, ALabelAloneIsReconstructedAsOnItsOwn) {
  SliceStack st = split_disc();
  // A third label far from the disc, on every slice: a small square.
  for (Slice& s : st.slices)
    for (int y = 2; y < 8; ++y)
      for (int x = 2; x < 8; ++x) s.image(x, y) = 3;
  ReconstructParams partition, independent;
  independent.label_partition = false;
  ReconstructOptions only3;
  only3.labels = {3};
  const ReconstructResult a = reconstruct(st, partition, only3), b = reconstruct(st, independent, only3);
  ASSERT_EQ(a.objects.size(), 1u);
  ASSERT_EQ(b.objects.size(), 1u);
  EXPECT_EQ(a.objects[0].mesh.vertices, b.objects[0].mesh.vertices);
  EXPECT_EQ(a.objects[0].mesh.triangles, b.objects[0].mesh.triangles);
}

}  // namespace
}  // namespace isoloft
