// Decimation against the Hausdorff oracle (validation issue, item 5): the
// decimated mesh stays closed and no part of the original surface lies
// farther from it than the requested error, as decided by CGAL's
// bounded-error Hausdorff distance, also with min_angle_deg (vertices moved).
#if defined(ISOLOFT_HAVE_VALIDATION)
#include <gtest/gtest.h>

#include "isoloft/mesh/decimate.h"
#include "isoloft/mesh/mesh_check.h"
#include "isoloft/pipeline.h"
#include "isoloft/synth/synth.h"
#include "validation/hausdorff.h"

using namespace isoloft;

namespace {
// decimate() bounds the distance of every ORIGINAL VERTEX to the result; a
// point inside an original triangle (sides ~1 px) can lie a little farther,
// by at most the sagitta of the decimated surface over one original
// triangle: well under 0.05 px for the curvatures of these shapes.
constexpr double kFaceInteriorSlack = 0.05;  // px
constexpr double kHausdorffErrorBound = 0.01;  // px, accuracy asked of CGAL
constexpr double kMinAngleDeg = 10;            // decimate.min_angle_deg: vertices moved, the same bound
}  // namespace

TEST(DecimationOracle, OriginalSurfaceStaysWithinTheErrorBound) {
  for (const std::string shape : {"sphere", "torus", "two-blobs"}) {
    SynthParams sp;
    sp.size = 48;
    sp.z_spacing = 4;
    const SynthResult syn = synthesize(*make_default_shape(shape, sp.size), sp);
    const ReconstructResult r = reconstruct(syn.stack, ReconstructParams{});
    ASSERT_EQ(r.objects.size(), 1u) << shape;
    const TriMesh original = r.objects[0].mesh;
    for (double e : {0.25, 0.75})
      for (double min_angle : {0.0, kMinAngleDeg}) {
        TriMesh mesh = original;
        DecimateParams dp;
        dp.max_error = e;
        dp.min_angle_deg = min_angle;
        const DecimateResult d = decimate(mesh, dp);
        SCOPED_TRACE(testing::Message() << shape << " e=" << e << " min angle " << min_angle);
        EXPECT_LT(d.triangles_after, d.triangles_before);
        const MeshCheck c = check_mesh(mesh);
        EXPECT_TRUE(c.closed && c.manifold && c.oriented);
        EXPECT_EQ(c.euler, r.objects[0].check.euler);
        const MeshDistanceReport h = mesh_distance(original, mesh, kHausdorffErrorBound);
        EXPECT_NE(hausdorff_verdict(h.a_to_b, e + kFaceInteriorSlack), Verdict::Fail)
            << "original->decimated Hausdorff in [" << h.a_to_b.lower << ", " << h.a_to_b.upper << "]";
      }
  }
}
#endif
