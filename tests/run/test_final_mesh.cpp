// What the run reads from an RT ROI's final mesh beside its check (its
// contour vertex distances and the volume table's clipped volumes): the same
// bits as measured on the finished run.
#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <vector>

#include "cli/cli_test_util.h"
#include "isoloft/run.h"

using namespace isoloft;

namespace {

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

}  // namespace

TEST(FinalMesh, ReadBesideTheCheckEqualsReadAfterTheRun) {
  InputRequest req;
  req.paths = {isoloft::test::kRtss};
  req.rois = {"Scar", "Tumor Bed"};
  const Inputs in = read_inputs(req);
  const RunResult r = run_jobs(in, ReconstructParams{}, {});
  ASSERT_EQ(r.objects.size(), 2u);
  for (std::size_t i = 0; i < r.objects.size(); ++i) {
    const ObjectResult& ob = r.objects[i].object;
    const Job& job = in.jobs[r.objects[i].job];
    ASSERT_FALSE(ob.mesh.empty()) << "object " << i;
    const std::vector<double> again = clipped_volumes(in, job, ob);
    ASSERT_EQ(ob.clipped_volumes.size(), again.size()) << "object " << i;
    ASSERT_EQ(again.size(), 3u) << "object " << i;
    for (std::size_t k = 0; k < again.size(); ++k)
      EXPECT_TRUE(same_bits(ob.clipped_volumes[k], again[k])) << "object " << i << " plane " << k << ": "
                                                             << ob.clipped_volumes[k] << " vs " << again[k];
    EXPECT_GT(again[0], again[2]) << "object " << i << ": above the first plane less than the whole";
    ASSERT_TRUE(ob.contour_distance) << "object " << i;
    const DistanceSummary d = summarize_distances(point_mesh_distances(ob.mesh, contour_vertices(job.stack)));
    EXPECT_EQ(ob.contour_distance->count, d.count) << "object " << i;
    EXPECT_TRUE(same_bits(ob.contour_distance->mean, d.mean)) << "object " << i;
    EXPECT_TRUE(same_bits(ob.contour_distance->p95, d.p95)) << "object " << i;
    EXPECT_TRUE(same_bits(ob.contour_distance->max, d.max)) << "object " << i;
  }
}
