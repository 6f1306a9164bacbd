// Decimation against the Hausdorff oracle (validation issue, item 5): the
// decimated mesh stays closed and no part of the original surface lies
// farther from it than the requested error, as decided by CGAL's
// bounded-error Hausdorff distance.
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
    for (double e : {0.25, 0.75}) {
      TriMesh mesh = original;
      DecimateParams dp;
      dp.max_error = e;
      const DecimateResult d = decimate(mesh, dp);
      EXPECT_LT(d.triangles_after, d.triangles_before) << shape << " e=" << e;
      const MeshCheck c = check_mesh(mesh);
      EXPECT_TRUE(c.closed && c.manifold && c.oriented) << shape << " e=" << e;
      EXPECT_EQ(c.euler, r.objects[0].check.euler) << shape << " e=" << e;
      const MeshDistanceReport h = mesh_distance(original, mesh, kHausdorffErrorBound);
      EXPECT_NE(hausdorff_verdict(h.a_to_b, e + kFaceInteriorSlack), Verdict::Fail)
          << shape << " e=" << e << ": original->decimated Hausdorff in [" << h.a_to_b.lower << ", " << h.a_to_b.upper << "]";
    }
  }
}
#endif
