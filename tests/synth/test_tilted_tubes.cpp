// The tilted-tube kit (synth/tilted_tubes.h): exact signed distances (a closest point
// on the surface, |value| its distance, outside and inside), the cuts it
// makes, its JSON round trip, and the sample counts of eval/volume.h on a
// mesh whose inside is known exactly.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "isoloft/core/error.h"
#include "isoloft/eval/volume.h"
#include "isoloft/synth/tilted_tubes.h"
#include "isoloft/synth/synth.h"

using namespace isoloft;

namespace {
// Exact closed forms in double: rounding of a few operations on values ~100 px.
constexpr double kExact = 1e-9;
}  // namespace

TEST(TiltedTubes, ValuesAreSignedDistancesToTheirClosestPoints) {
  for (const std::string& name : tilted_kit_names()) {
    const TiltedCase c = tilted_kit_case(name);
    const auto [lo, hi] = c.shape->bounds();
    for (int i = 0; i < 40; ++i) {
      const Vec3d p = lo + (hi - lo).cwiseProduct(Vec3d((i * 37 % 40 + 0.31) / 40.0, (i * 11 % 40 + 0.17) / 40.0,
                                                        (i * 23 % 40 + 0.23) / 40.0));
      const Vec3d q = c.shape->closest_point(p);
      EXPECT_NEAR(c.shape->value(q), 0.0, kExact) << name << " sample " << i;
      if (c.shape->value(p) < 0)  // outside: exact for every kit shape
        EXPECT_NEAR(-c.shape->value(p), (p - q).norm(), kExact) << name << " sample " << i;
    }
    const auto back = shape_from_json(c.shape->to_json());
    EXPECT_EQ(back->value(lo + 0.37 * (hi - lo)), c.shape->value(lo + 0.37 * (hi - lo))) << name;
  }
}

TEST(TiltedTubes, KitCasesCutWhatTheySay) {
  for (const std::string& name : tilted_kit_names()) {
    const TiltedCase c = tilted_kit_case(name);
    const SynthResult s = synthesize(c, InputKind::Masks);
    ASSERT_EQ(s.stack.slices.size(), c.slice_z.size()) << name;
    EXPECT_EQ(s.description["components"], c.components) << name;
    int with_inside = 0;
    for (const Slice& sl : s.stack.slices) {
      bool any = false;
      for (const auto v : sl.image.data) any = any || v != 0;
      with_inside += any;
      for (int x = 0; x < sl.image.width; ++x)  // the margin: nothing on the border
        EXPECT_EQ(sl.image(x, 0), 0u) << name;
    }
    // Tubes cross every slice; the separate objects lie on some.
    if (c.components == 1) EXPECT_EQ(with_inside, int(c.slice_z.size())) << name;
  }
  // The 80 deg tube: consecutive ellipses do not overlap.
  const SynthResult t = synthesize(tilted_kit_case("tube80_r3_s8"), InputKind::Masks);
  for (std::size_t k = 0; k + 1 < t.stack.slices.size(); ++k) {
    long both = 0;
    for (std::size_t i = 0; i < t.stack.slices[k].image.size(); ++i)
      both += t.stack.slices[k].image.data[i] && t.stack.slices[k + 1].image.data[i];
    EXPECT_EQ(both, 0) << "slices " << k << ", " << k + 1;
  }
  EXPECT_THROW(tilted_kit_case("tube"), ParamError);
  EXPECT_THROW(make_tilted_shape("cone", {}), ParamError);
  EXPECT_THROW(tilted_tube(90, 3, 8), ParamError);
}

TEST(TiltedTubes, GenericShapesTakeTheirOptions) {
  TiltedOptions o;
  o.tilt = 70, o.radius = 4, o.spacing = 8;
  const TiltedCase a = make_tilted_shape("tube", o), b = tilted_kit_case("tube70_r4_s8");
  EXPECT_EQ(a.shape->to_json(), b.shape->to_json());
  EXPECT_EQ(a.slice_z, b.slice_z);
  o.slices = 9;
  EXPECT_EQ(make_tilted_shape("tube", o).slice_z.size(), 9u);
  EXPECT_EQ(make_tilted_shape("two-spheres", o).components, 2);
}

// A box [2, 7] x [3, 5] x [1, 4] as 12 outward triangles: grid points off
// its faces, counted by brute force; and a sheared copy (slanted faces).
TEST(EvalVolume, CountsTheSamplesInsideAClosedMesh) {
  TriMesh box;
  for (int i = 0; i < 8; ++i)
    box.vertices.emplace_back(i & 1 ? 7.f : 2.f, i & 2 ? 5.f : 3.f, i & 4 ? 4.f : 1.f);
  box.triangles = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                   {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  SampleGrid g;
  g.origin = Vec3d(0.1, 0.2, 0.3);
  g.step_xy = 0.5, g.step_z = 0.5;
  g.nx = g.ny = 24, g.nz = 12;
  for (const double shear : {0.0, 0.7}) {
    TriMesh m = box;
    for (Vec3f& v : m.vertices) v.x() += float(shear) * v.z();
    long want = 0;
    for (int k = 0; k < g.nz; ++k)
      for (int j = 0; j < g.ny; ++j)
        for (int i = 0; i < g.nx; ++i) {
          const Vec3d p = g.origin + Vec3d(i * 0.5, j * 0.5, k * 0.5);
          const double x = p.x() - shear * p.z();
          want += x > 2 && x < 7 && p.y() > 3 && p.y() < 5 && p.z() > 1 && p.z() < 4;
        }
    ASSERT_GT(want, 0);
    EXPECT_EQ(mesh_inside_samples(m, g), want) << "shear " << shear;
  }
}
