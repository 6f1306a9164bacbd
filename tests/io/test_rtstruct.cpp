// DICOM RT Structure Sets (io/rtstruct.h): the real breast structure set in
// data/rtstruct (a copy of ../shared/data/rtstruct), keyhole and XOR contours made by hand, and the
// reconstruction of Heart and Lt Lung against their own contour vertices.
#include <gtest/gtest.h>

#include "dcmtk/config/osconfig.h"
#include "dcmtk/dcmdata/dcdeftag.h"
#include "dcmtk/dcmdata/dcfilefo.h"
#include "dcmtk/dcmdata/dcstack.h"
#include "dcmtk/dcmdata/dcuid.h"
#include "dcmtk/dcmrt/drtstrct.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <cmath>
#include <numeric>
#include <string>
#include <vector>

#include "isoloft/core/error.h"
#include "isoloft/io/rtstruct.h"
#include "isoloft/io/rtstruct_sections.h"
#include "io/io_test_util.h"
#include "isoloft/mesh/mesh_check.h"
#include "isoloft/mesh/plane_cut.h"
#include "isoloft/pipeline.h"
#include "isoloft/run/inputs.h"
#include "validation/hausdorff.h"

using namespace isoloft;

namespace {

const std::string kRtss = std::string(ISOLOFT_SOURCE_DIR) + "/data/rtstruct/rtss.dcm";

// The vertices of the contours the stack keeps (loops of at least a pixel), patient mm.
std::vector<Vec3d> kept_vertices(const SliceStack& st) {
  std::vector<Vec3d> out;
  for (const auto& s : st.slices)
    for (const auto& poly : s.polygons)
      for (const Vec2d& p : poly.points) out.push_back(st.patient->to_patient(Vec3d(p.x(), p.y(), s.z)));
  return out;
}

std::size_t closed_vertices(const RtRoi& roi) {
  std::size_t n = 0;
  for (const auto& c : roi.contours) n += c.type == "CLOSED_PLANAR" ? c.points.size() : 0;
  return n;
}

TriMesh in_patient_mm(const TriMesh& m, const PatientFrame& f) {
  TriMesh out = m;
  for (auto& v : out.vertices) v = f.to_patient(v.cast<double>()).cast<float>();
  return out;
}

using Contour = std::vector<Vec3d>;

// The real structure set with Heart's contours replaced by `contours`
// (hand-made files on a real header).
void write_heart_as(const std::string& out, const std::vector<Contour>& contours) {
  DcmFileFormat ff;
  ASSERT_TRUE(ff.loadFile(kRtss.c_str()).good());
  DRTStructureSetIOD rt;
  ASSERT_TRUE(rt.read(*ff.getDataset()).good());
  DRTROIContourSequence& rcs = rt.getROIContourSequence();
  for (std::size_t r = 0; r < rcs.getNumberOfItems(); ++r) {
    Sint32 ref = -1;
    rcs.getItem(r).getReferencedROINumber(ref);
    if (ref != 5) continue;  // Heart
    DRTContourSequence& cs = rcs.getItem(r).getContourSequence();
    cs.clear();
    for (const Contour& c : contours) {
      DRTContourSequence::Item* item = nullptr;
      ASSERT_TRUE(cs.addItem(item).good());
      std::string data;
      for (const Vec3d& p : c)
        for (double v : {p.x(), p.y(), p.z()}) data += (data.empty() ? "" : "\\") + std::to_string(v);
      item->setContourGeometricType("CLOSED_PLANAR");
      item->setNumberOfContourPoints(std::to_string(c.size()).c_str());
      item->setContourData(data.c_str());
    }
  }
  ASSERT_TRUE(rt.write(*ff.getDataset()).good());
  ASSERT_TRUE(ff.saveFile(out.c_str(), EXS_LittleEndianExplicit).good());
}

// A square of side a (mm) centred at (cx, cy) on plane z, counter-clockwise.
Contour square(double cx, double cy, double a, double z) {
  const double h = a / 2;
  return {{cx - h, cy - h, z}, {cx + h, cy - h, z}, {cx + h, cy + h, z}, {cx - h, cy + h, z}};
}

// The outer square with the inner one cut in along a zero-width keyhole from
// the outer's corner 0 to the inner's corner 0, traversed out and back.
Contour keyhole(const Contour& outer, const Contour& inner) {
  Contour c{outer[0], inner[0]};
  for (std::size_t i = inner.size() - 1; i > 0; --i) c.push_back(inner[i]);  // the hole the other way round
  c.push_back(inner[0]);
  for (const Vec3d& p : outer) c.push_back(p);
  return c;
}

ReconstructResult reconstruct_heart(const std::string& path) {
  std::vector<std::string> warnings;
  const SliceStack st = roi_stack(*read_rtstruct(path).find("Heart"), RoiGrid{}, path, warnings);
  return reconstruct(st, ReconstructParams{});
}

double quantile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  return v[std::size_t(std::floor(q * double(v.size() - 1)))];
}

}  // namespace

TEST(RtStruct, ReadsTheRoisOfTheBreastStructureSet) {
  const RtStructureSet set = read_rtstruct(kRtss);
  ASSERT_EQ(set.rois.size(), 10u);
  const RtRoi* heart = set.find("Heart");
  ASSERT_NE(heart, nullptr);
  EXPECT_EQ(heart->number, 5);
  EXPECT_EQ(heart->closed_contours(), 33);
  ASSERT_NE(set.find("lt lung"), nullptr) << "names match ignoring case";
  EXPECT_EQ(set.find("Lt Lung")->closed_contours(), 165);
  EXPECT_EQ(set.find("Areola")->contours.size(), 0u);
  EXPECT_EQ(set.find("Nowhere"), nullptr);
  for (const Vec3d& p : heart->contours.front().points) EXPECT_NEAR(p.z(), -98.44, 1e-9);
}

// Acceptance (medical-formats issue): 95 % of the contour vertices of Heart
// and Lt Lung within 0.5 mm of their mesh, all within 1 mm, for the paper's
// fit (mpu.tol 0.75 px = 0.375 mm on the default 0.5 mm grid, plus Marching
// Cubes' chords). The default takes the polygons as drawn: the slice field is
// the exact distance to their edges, so only Marching Cubes' chords between
// pixel samples part the mesh from a vertex: 95 % within a fifth of a pixel,
// all within one. Lt Lung holds sub-pixel specks (4-point contours 0.1-0.7 mm
// across) that the grid cannot hold and roi_stack drops; they are at most this
// share of its vertices.
constexpr double kP95Mm = 0.5, kMaxMm = 1.0;
constexpr double kDrawnP95Mm = 0.1, kDrawnMaxMm = 0.5;
constexpr double kMaxDroppedShare = 0.005;

TEST(RtStruct, HeartAndLungMeshesPassThroughTheirContours) {
  const RtStructureSet set = read_rtstruct(kRtss);
  for (const char* name : {"Heart", "Lt Lung"}) {
    const RtRoi& roi = *set.find(name);
    std::vector<std::string> warnings;
    const SliceStack st = roi_stack(roi, RoiGrid{}, kRtss, warnings);
    ASSERT_TRUE(st.patient.has_value());
    const std::vector<Vec3d> vertices = kept_vertices(st);
    EXPECT_LE(double(closed_vertices(roi) - vertices.size()), kMaxDroppedShare * double(closed_vertices(roi))) << name;
    double p95_of[2] = {0, 0};
    for (const PolylineBoundary boundary : {PolylineBoundary::Fit, PolylineBoundary::Drawn}) {
      ReconstructParams params;
      params.polyline_boundary = boundary;
      const ReconstructResult r = reconstruct(st, params);
      ASSERT_EQ(r.objects.size(), 1u) << name;
      EXPECT_TRUE(r.objects[0].check.closed && r.objects[0].check.manifold) << name;
      const std::vector<double> d = point_to_mesh_distances(in_patient_mm(r.objects[0].mesh, *st.patient), vertices);
      const double p95 = quantile(d, 0.95), worst = *std::max_element(d.begin(), d.end());
      const double mean = std::accumulate(d.begin(), d.end(), 0.0) / double(d.size());
      const bool drawn = boundary == PolylineBoundary::Drawn;
      std::printf("%s, %s: %zu of %zu vertices kept, mean %.3f mm, p95 %.3f mm, max %.3f mm\n", name,
                  drawn ? "drawn" : "fit", d.size(), closed_vertices(roi), mean, p95, worst);
      EXPECT_LE(p95, drawn ? kDrawnP95Mm : kP95Mm) << name << (drawn ? " drawn" : " fit");
      EXPECT_LE(worst, drawn ? kDrawnMaxMm : kMaxMm) << name << (drawn ? " drawn" : " fit");
      p95_of[drawn] = p95;
    }
    EXPECT_LT(p95_of[1], p95_of[0]) << name << ": the polygons as drawn should be nearer their own vertices than the fit";
  }
}

// The triangle budget (run/inputs.cpp): without --voxel-size, BODY (about 5 M
// triangles at 0.5 mm by its contours) gets the grid that keeps its mesh
// within 1.5 M triangles, with a warning naming it; then its narrowest drawn
// contours (0.67 mm thick) refine it again, from that grid to one finer but
// above 0.5 mm, within 4 M triangles, reported; the other ROIs keep their
// grid; --voxel-size keeps the grid asked for.
constexpr double kRtRefinedMeshBudget = 4e6;

TEST(RtStruct, TheLargestRoiGetsTheGridOfTheTriangleBudget) {
  InputRequest request;
  request.paths = {kRtss};
  const Inputs in = read_inputs(request);
  const Job* body = nullptr;
  for (const Job& job : in.jobs) {
    if (job.name == "BODY") body = &job;
    else EXPECT_LE(job.stack.pixel_size, 0.5) << job.name;
  }
  ASSERT_NE(body, nullptr);
  EXPECT_GT(body->stack.pixel_size, 0.5);
  EXPECT_TRUE(std::any_of(in.warnings.begin(), in.warnings.end(), [](const std::string& w) {
    return w.find("ROI 'BODY': working grid") != std::string::npos;
  }));
  ASSERT_TRUE(body->refined.has_value());
  EXPECT_EQ(body->refined->to_mm, body->stack.pixel_size);
  EXPECT_LT(body->refined->to_mm, body->refined->from_mm);
  EXPECT_FALSE(body->refined->limited);
  EXPECT_TRUE(std::any_of(in.warnings.begin(), in.warnings.end(), [](const std::string& w) {
    return w.find("ROI 'BODY': working grid refined from") != std::string::npos;
  }));
  const ReconstructResult r = reconstruct(body->stack, ReconstructParams{});
  ASSERT_EQ(r.objects.size(), 1u);
  EXPECT_TRUE(r.objects[0].check.closed && r.objects[0].check.manifold);
  EXPECT_LE(double(r.objects[0].mesh.triangles.size()), kRtRefinedMeshBudget);
  request.voxel_size = 0.5;
  request.rois = {"BODY"};
  EXPECT_EQ(read_inputs(request).jobs.at(0).stack.pixel_size, 0.5);
}

// Holes and islands by the XOR (even-odd) rule: a 40 mm square with a 16 mm
// square hole on three planes is a tube (genus 1); with a 6 mm island in the
// hole, two pieces.
TEST(RtStruct, XorHolesAndIslands) {
  isoloft::test::TempDir dir;
  std::vector<Contour> tube, nested;
  for (double z : {0.0, 3.0, 6.0}) {
    tube.push_back(square(0, 0, 40, z));
    tube.push_back(square(0, 0, 16, z));
    nested.push_back(square(0, 0, 40, z));
    nested.push_back(square(0, 0, 16, z));
    nested.push_back(square(0, 0, 6, z));
  }
  write_heart_as(dir.file("tube.dcm"), tube);
  write_heart_as(dir.file("nested.dcm"), nested);
  const ReconstructResult t = reconstruct_heart(dir.file("tube.dcm"));
  ASSERT_EQ(t.objects.size(), 1u);
  EXPECT_TRUE(t.objects[0].check.closed && t.objects[0].check.manifold);
  EXPECT_EQ(t.objects[0].check.components, 1);
  EXPECT_EQ(t.objects[0].check.euler, 0) << "a tube: genus 1";
  const ReconstructResult n = reconstruct_heart(dir.file("nested.dcm"));
  ASSERT_EQ(n.objects.size(), 1u);
  EXPECT_EQ(n.objects[0].check.components, 2) << "the island is its own piece";
}

// A keyhole contour (the hole joined to the outer contour by a zero-width
// cut) gives the XOR tube's surface: the cut leaves no trace.
constexpr double kKeyholeSameMm = 0.05;  // the loops start at other vertices: sampling differs by a fraction of a pixel

TEST(RtStruct, KeyholeContoursComeOutAsTheirLoops) {
  isoloft::test::TempDir dir;
  std::vector<Contour> xor_set, keyholed;
  for (double z : {0.0, 3.0, 6.0}) {
    const Contour outer = square(0, 0, 40, z), inner = square(0, 0, 16, z);
    xor_set.push_back(outer);
    xor_set.push_back(inner);
    keyholed.push_back(keyhole(outer, inner));
  }
  write_heart_as(dir.file("xor.dcm"), xor_set);
  write_heart_as(dir.file("keyhole.dcm"), keyholed);
  std::vector<std::string> warnings;
  const SliceStack ks = roi_stack(*read_rtstruct(dir.file("keyhole.dcm")).find("Heart"), RoiGrid{}, "k", warnings);
  for (const auto& s : ks.slices) EXPECT_EQ(s.polygons.size(), 2u) << "one keyhole contour, two loops";
  const ReconstructResult a = reconstruct_heart(dir.file("xor.dcm")), b = reconstruct_heart(dir.file("keyhole.dcm"));
  ASSERT_EQ(b.objects.size(), 1u);
  EXPECT_EQ(b.objects[0].check.euler, 0) << "a tube, as the XOR contours give";
  std::vector<Vec3d> vb;
  for (const auto& v : b.objects[0].mesh.vertices) vb.push_back(v.cast<double>());
  double worst = 0;
  for (double d : point_to_mesh_distances(a.objects[0].mesh, vb)) worst = std::max(worst, d);
  EXPECT_LE(worst * RoiGrid{}.voxel_size, kKeyholeSameMm);
}

TEST(RtStruct, SplitKeyholesHandlesCutsNestedCutsAndSpikes) {
  const std::vector<Vec2d> outer{{0, 0}, {10, 0}, {10, 10}, {0, 10}};
  // outer[0] -> (3,3) around a hole back to (3,3) -> outer[0] -> the rest.
  const std::vector<Vec2d> cut{{0, 0}, {3, 3}, {3, 6}, {6, 6}, {6, 3}, {3, 3}, {0, 0}, {10, 0}, {10, 10}, {0, 10}};
  const auto loops = detail::split_keyholes(cut, 1e-6);
  ASSERT_EQ(loops.size(), 2u);
  std::size_t sizes = loops[0].size() + loops[1].size();
  EXPECT_EQ(sizes, 8u) << "4 + 4 vertices, the cut's repeated ends dropped";
  const std::vector<Vec2d> spike{{0, 0}, {10, 0}, {10, 5}, {15, 5}, {10, 5}, {10, 10}, {0, 10}};
  const auto s = detail::split_keyholes(spike, 1e-6);
  ASSERT_EQ(s.size(), 1u) << "a zero-width spike is cut off";
  EXPECT_EQ(s[0].size(), 5u);
  EXPECT_EQ(detail::split_keyholes(outer, 1e-6).size(), 1u);
}

TEST(RtStruct, BadFilesAndRoisAreClearErrors) {
  isoloft::test::TempDir dir;
  auto expect_error = [](auto&& f, const std::string& words) {
    try {
      f();
      ADD_FAILURE() << "accepted (" << words << ")";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  // Truncated.
  std::ifstream in(kRtss, std::ios::binary);
  std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::ofstream(dir.file("trunc.dcm"), std::ios::binary).write(bytes.data(), std::streamsize(bytes.size() / 3));
  expect_error([&] { (void)read_rtstruct(dir.file("trunc.dcm")); }, "not a readable DICOM file");
  isoloft::test::write_text(dir.file("junk.dcm"), "hello");
  expect_error([&] { (void)read_rtstruct(dir.file("junk.dcm")); }, "not a readable DICOM file");
  // A DICOM of another SOP class.
  DcmFileFormat ff;
  ASSERT_TRUE(ff.loadFile(kRtss.c_str()).good());
  ff.getDataset()->putAndInsertString(DCM_SOPClassUID, UID_CTImageStorage);
  ASSERT_TRUE(ff.saveFile(dir.file("ct.dcm").c_str(), EXS_LittleEndianExplicit).good());
  expect_error([&] { (void)read_rtstruct(dir.file("ct.dcm")); }, "not a DICOM RT Structure Set (SOP class CTImageStorage)");
  // A ROI without contours, an oblique and a non-planar one.
  const RtStructureSet set = read_rtstruct(kRtss);
  std::vector<std::string> w;
  expect_error([&] { (void)roi_stack(*set.find("Areola"), RoiGrid{}, kRtss, w); }, "ROI 'Areola' has no closed planar contour");
  RtRoi tilted{99, "Tilted", std::nullopt, {}};
  for (double z : {0.0, 3.0}) {
    RtContour c{"CLOSED_PLANAR", {}};
    for (const Vec3d& p : square(0, 0, 20, z)) c.points.push_back(p + Vec3d(0, 0, 0.2 * p.x()));  // a plane tilted in x
    tilted.contours.push_back(c);
  }
  expect_error([&] { (void)roi_stack(tilted, RoiGrid{}, "t.dcm", w); }, "ROI 'Tilted' contour 0 lies on an oblique plane");
  tilted.contours[0].points[2].z() += 1.0;
  expect_error([&] { (void)roi_stack(tilted, RoiGrid{}, "t.dcm", w); }, "ROI 'Tilted' contour 0 is not planar");
  RtRoi open{98, "Open", std::nullopt, {{"OPEN_PLANAR", square(0, 0, 20, 0)}, {"CLOSED_PLANAR", square(0, 0, 20, 3)},
                                        {"CLOSED_PLANAR", square(0, 0, 20, 6)}}};
  w.clear();
  EXPECT_NO_THROW((void)roi_stack(open, RoiGrid{}, "o.dcm", w));
  ASSERT_EQ(w.size(), 1u);
  EXPECT_NE(w[0].find("ROI 'Open': 1 contour(s) not CLOSED_PLANAR"), std::string::npos) << w[0];
}

// Planes with no contour inside a ROI's z range (two lobes with a gap) get
// empty slices, so each lobe closes instead of being bridged.
TEST(RtStruct, GapsBetweenContourPlanesCloseBothSides) {
  RtRoi two{1, "Two", std::nullopt, {}};
  for (double z : {0.0, 3.0, 6.0, 18.0, 21.0, 24.0}) two.contours.push_back({"CLOSED_PLANAR", square(0, 0, 20, z)});
  std::vector<std::string> w;
  const SliceStack st = roi_stack(two, RoiGrid{}, "two.dcm", w);
  EXPECT_EQ(st.slices.size(), 6u + 3u) << "z 9, 12, 15 inserted empty";
  const ReconstructResult r = reconstruct(st, ReconstructParams{});
  ASSERT_EQ(r.objects.size(), 1u);
  EXPECT_EQ(r.objects[0].check.components, 2);
}

namespace {

// A circle of radius r (mm) centred at (cx, cy) on plane z, n vertices.
Contour circle(double cx, double cy, double r, double z, int n = 64) {
  Contour c;
  for (int i = 0; i < n; ++i) {
    const double t = 2 * M_PI * i / n;
    c.emplace_back(cx + r * std::cos(t), cy + r * std::sin(t), z);
  }
  return c;
}

// Two spheres of radius 15 mm side by side, cut every 3 mm; each contour's z
// moved by +-`jitter` mm (alternating sign, as decimal rounding scatters them).
RtRoi two_spheres(double jitter) {
  RtRoi roi{1, "Lungs", std::nullopt, {}};
  int i = 0;
  for (double z = -12; z <= 12; z += 3)
    for (double cx : {-20.0, 20.0}) {
      const double dz = (i++ % 2 ? 1 : -1) * jitter;
      roi.contours.push_back({"CLOSED_PLANAR", circle(cx, 0, std::sqrt(225 - z * z), z + dz)});
    }
  return roi;
}

}  // namespace

// Contours whose z differ by rounding share their plane (issue 27): an island
// 0.02 mm off its plane no longer cuts the objects there, and 0.02-0.04 mm of
// jitter no longer makes 0.02 mm the slice step.
// Jitter moves each contour by at most 0.04 mm of a 3 mm step (1.3 %): the
// volume moves by less than this share.
constexpr double kJitterVolumeShare = 0.01;

TEST(RtStruct, ContoursOffTheirPlaneByRoundingShareIt) {
  RtRoi lobes{1, "Lobes", std::nullopt, {}};
  for (int k = 0; k < 5; ++k) {
    lobes.contours.push_back({"CLOSED_PLANAR", square(-10, 0, 10, 3.0 * k)});
    lobes.contours.push_back({"CLOSED_PLANAR", square(10, 0, 10, 3.0 * k + (k == 2 ? 0.02 : 0.0))});
  }
  RoiGrid grid;
  grid.plane_spacing = 3;
  std::vector<std::string> w;
  const SliceStack st = roi_stack(lobes, grid, "lobes.dcm", w);
  EXPECT_EQ(st.slices.size(), 5u);
  ASSERT_EQ(w.size(), 1u);
  EXPECT_NE(w[0].find("differ by up to 0.02"), std::string::npos) << w[0];
  ReconstructParams levin = method_defaults(Method::Levin);
  EXPECT_EQ(reconstruct(st, levin).objects.at(0).check.components, 2);

  w.clear();
  const SliceStack clean = roi_stack(two_spheres(0), grid, "s.dcm", w), jittered = roi_stack(two_spheres(0.03), grid, "s.dcm", w);
  EXPECT_EQ(jittered.slices.size(), 9u) << "one slice per 3 mm plane";
  const ObjectResult a = reconstruct(clean, levin).objects.at(0), b = reconstruct(jittered, levin).objects.at(0);
  EXPECT_EQ(b.check.components, 2);
  EXPECT_NEAR(b.check.volume, a.check.volume, kJitterVolumeShare * a.check.volume);
}

TEST(RtStruct, RoisByNameOrNumberAndDuplicatesAreErrorsNamingThem) {
  auto roi = [](int n, const char* name) {
    return RtRoi{n, name, std::nullopt, {{"CLOSED_PLANAR", square(0, 0, 10, 0)}, {"CLOSED_PLANAR", square(0, 0, 10, 3)}}};
  };
  RtStructureSet set;
  set.rois = {roi(5, "Heart"), roi(7, "Lung"), roi(8, "Lung"), roi(12, "5b")};
  EXPECT_EQ(set.select({"7"}, "x.dcm").at(0)->name, "Lung") << "by number";
  EXPECT_EQ(set.select({"heart", "5"}, "x.dcm").size(), 1u) << "by name and number: one ROI once";
  auto error = [&](const std::vector<std::string>& wanted) {
    try {
      (void)set.select(wanted, "x.dcm");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(error({"Lung"}).find("2 ROIs are named 'Lung': 'Lung' (number 7), 'Lung' (number 8)"), std::string::npos)
      << error({"Lung"});
  EXPECT_NE(error({"Nowhere"}).find("'Heart' (number 5)"), std::string::npos) << "the ROIs listed";
  std::vector<std::string> w;
  try {
    (void)set.with_contours("x.dcm", w);
    ADD_FAILURE() << "two ROIs named Lung accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("select them by number"), std::string::npos) << e.what();
  }
  // One number, two ROIs: read_rtstruct marks both; their contours are nobody's.
  set.rois = {roi(9, "A"), roi(9, "B")};
  set.rois[0].number_shared = set.rois[1].number_shared = true;
  EXPECT_NE(error({"B"}).find("ROI number 9 is used by 2 ROIs ('A', 'B')"), std::string::npos) << error({"B"});
  EXPECT_THROW((void)set.with_contours("x.dcm", w), InputError);
}

// A ROI on one plane is a slab of one slice spacing closed by the end caps:
// its contours a quarter spacing either side, the caps cap_extent of that
// half spacing beyond; nothing beyond (plus the half pixel a Marching Cubes
// vertex may lie off its plane).
TEST(RtStruct, OnePlaneRoiIsAClosedSurfaceWithinItsSlab) {
  RtRoi dot{3, "Dot", std::nullopt, {{"CLOSED_PLANAR", circle(0, 0, 2.0, 10.0)}}};
  RoiGrid grid;
  std::vector<std::string> w;
  EXPECT_THROW((void)roi_stack(dot, grid, "d.dcm", w), InputError) << "no spacing known";
  grid.plane_spacing = 3;
  const SliceStack st = roi_stack(dot, grid, "d.dcm", w);
  ASSERT_EQ(st.slices.size(), 2u) << "its contours a quarter spacing below and above";
  EXPECT_EQ(rt_planes(st), std::vector<double>{10.0});
  const ReconstructResult r = reconstruct(st, ReconstructParams{});
  ASSERT_EQ(r.objects.size(), 1u);
  const ObjectResult& o = r.objects[0];
  EXPECT_TRUE(o.check.closed && o.check.manifold && o.check.oriented);
  const double reach = (0.25 + 0.5 * ReconstructParams{}.interp.cap_extent) * grid.plane_spacing + 0.5 * grid.voxel_size;
  for (const Vec3f& v : o.mesh.vertices) {
    const double z = st.patient->to_patient(v.cast<double>()).z();
    ASSERT_LE(std::abs(z - 10.0), reach) << z;
  }
}

namespace {

// Distance from p to the nearest edge of the loops.
double to_loops(const Vec2d& p, const std::vector<std::vector<Vec2d>>& loops) {
  double best = INFINITY;
  for (const auto& l : loops)
    for (std::size_t i = 0, j = l.size() - 1; i < l.size(); j = i++) {
      const Vec2d a = l[j], d = l[i] - l[j];
      const double t = std::clamp((p - a).dot(d) / std::max(d.squaredNorm(), 1e-300), 0.0, 1.0);
      best = std::min(best, (a + t * d - p).norm());
    }
  return best;
}

std::map<double, std::vector<std::vector<Vec2d>>> loops_by_plane(const RtRoi& roi) {
  std::map<double, std::vector<std::vector<Vec2d>>> out;
  for (const auto& c : roi.contours) {
    std::vector<Vec2d> l;
    for (const Vec3d& p : c.points) l.emplace_back(p.x(), p.y());
    out[std::round(c.points.front().z() * 100) / 100].push_back(l);
  }
  return out;
}

}  // namespace

// Back to the planning system: Tumor Bed reconstructed, cut at its planes,
// written as an RT Structure Set on the input's header and read back. Its
// number, name, colour and frame of reference are kept; on each input plane
// the written and the input contours lie within kRoundTripMeanMm (the
// issue's target) of each other, as the mean of the two directed mean
// distances (the input's corners, which the fitted curve rounds, weigh on
// one direction: measured 0.109 mm one way, 0.075 mm the other), and the
// written set reconstructs to the same volume within kRoundTripVolumeShare
// (the target).
constexpr double kRoundTripMeanMm = 0.1;
constexpr double kRoundTripVolumeShare = 0.005;

TEST(RtStructWrite, TumorBedComesBackOnItsPlanes) {
  isoloft::test::TempDir dir;
  const RtStructureSet set = read_rtstruct(kRtss);
  const RtRoi& roi = *set.find("Tumor Bed");
  RoiGrid grid;
  grid.plane_spacing = typical_plane_spacing(set);
  std::vector<std::string> w;
  const SliceStack st = roi_stack(roi, grid, kRtss, w);
  const ObjectResult first = reconstruct(st, ReconstructParams{}).objects.at(0);
  RtRoiContours out{&roi, {}};
  for (const Slice& s : st.slices) {
    if (s.polygons.empty()) continue;
    RtRoiContours::Plane plane{st.patient->to_patient(Vec3d(0, 0, s.z)).z(), {}};
    for (const auto& loop : cut_mesh(first.mesh, s.z)) {
      std::vector<Vec2d> mm;
      for (const Vec2d& p : loop) mm.push_back(st.patient->to_patient(Vec3d(p.x(), p.y(), s.z)).head<2>());
      plane.loops.push_back(mm);
    }
    out.planes.push_back(plane);
  }
  write_rtstruct(dir.file("out.dcm"), kRtss, {out}, "isoloft test");
  const RtStructureSet back = read_rtstruct(dir.file("out.dcm"));
  ASSERT_EQ(back.rois.size(), 1u) << "only the ROI written";
  EXPECT_EQ(back.rois[0].name, "Tumor Bed");
  EXPECT_EQ(back.rois[0].number, roi.number);
  ASSERT_TRUE(back.rois[0].color && roi.color);
  EXPECT_EQ(*back.rois[0].color, *roi.color);
  EXPECT_EQ(back.frame_of_reference, set.frame_of_reference);
  const auto in = loops_by_plane(roi), again = loops_by_plane(back.rois[0]);
  ASSERT_EQ(again.size(), in.size()) << "one written plane per input plane";
  double sum_in = 0, sum_out = 0;
  long n_in = 0, n_out = 0;
  for (const auto& [z, loops] : in) {
    ASSERT_TRUE(again.count(z)) << "plane z = " << z;
    for (const auto& l : loops)
      for (const Vec2d& p : l) sum_in += to_loops(p, again.at(z)), ++n_in;
    for (const auto& l : again.at(z))
      for (const Vec2d& p : l) sum_out += to_loops(p, loops), ++n_out;
  }
  std::printf("Tumor Bed: input vertices %.4f mm from the written contours on average, written %.4f mm from the input\n",
              sum_in / double(n_in), sum_out / double(n_out));
  EXPECT_LE(0.5 * (sum_in / double(n_in) + sum_out / double(n_out)), kRoundTripMeanMm);
  const SliceStack st2 = roi_stack(back.rois[0], grid, dir.file("out.dcm"), w);
  const ObjectResult second = reconstruct(st2, ReconstructParams{}).objects.at(0);
  std::printf("Tumor Bed: volume %.1f mm^3, after the round trip %.1f mm^3\n", first.check.volume * 0.125,
              second.check.volume * 0.125);
  EXPECT_NEAR(second.check.volume, first.check.volume, kRoundTripVolumeShare * first.check.volume);
}

// The analytic kit's core case (experiments/rt_kit.py has the whole table):
// a 10 mm sphere cut every 2 mm, centred on a plane. isoloft's slab caps keep
// its volume within kSlabCapShare of the slab rule (contour area x spacing,
// which is unbiased over where planes cut a shape; measured departures of
// the caps on 5-15 mm spheres: up to 2.5 %); the old dome lost 5-16 % here.
constexpr double kSlabCapShare = 0.03;

TEST(RtStruct, SphereVolumeFollowsTheSlabRule) {
  RtRoi ball{1, "Ball", std::nullopt, {}};
  double slab = 0;
  for (double z = -4; z <= 4; z += 2) {
    const double r = std::sqrt(25 - z * z);
    ball.contours.push_back({"CLOSED_PLANAR", circle(0, 0, r, z, 128)});
    slab += 128 * 0.5 * r * r * std::sin(2 * M_PI / 128) * 2.0;  // the 128-gon's area x 2 mm
  }
  RoiGrid grid;
  grid.plane_spacing = 2;
  std::vector<std::string> w;
  const SliceStack st = roi_stack(ball, grid, "ball.dcm", w);
  const ObjectResult o = reconstruct(st, ReconstructParams{}).objects.at(0);
  EXPECT_TRUE(o.check.closed && o.check.manifold && o.check.oriented);
  const double mm3 = o.check.volume * std::pow(grid.voxel_size, 3);
  std::printf("10 mm sphere on 2 mm planes: %.1f mm^3, slab rule %.1f, truth %.1f\n", mm3, slab, 4.0 / 3 * M_PI * 125);
  EXPECT_NEAR(mm3, slab, kSlabCapShare * slab);
}

// A ROI whose contours enclose no area says so (not only "no contour"), and
// contours of a ROI number the structure set does not list are counted, so
// the run can warn about them instead of dropping them silently.
TEST(RtStruct, ZeroAreaContoursAndUnlistedRoiContoursSayWhy) {
  const std::string dir = testing::TempDir() + "isoloft_rt_zero_area";
  std::filesystem::create_directories(dir);
  const std::string flat = dir + "/flat.dcm";
  write_heart_as(flat, {{{0, 0, 0}, {10, 10, 0}, {20, 20, 0}}, {{0, 0, 3}, {10, 10, 3}, {20, 20, 3}}});
  std::vector<std::string> w;
  try {
    (void)roi_stack(*read_rtstruct(flat).find("Heart"), RoiGrid{}, flat, w);
    ADD_FAILURE() << "collinear contours accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("2 of them no area at all: zero net area"), std::string::npos) << e.what();
  }

  const std::string unlisted = dir + "/unlisted.dcm";
  DcmFileFormat ff;
  ASSERT_TRUE(ff.loadFile(kRtss.c_str()).good());
  DRTStructureSetIOD rt;
  ASSERT_TRUE(rt.read(*ff.getDataset()).good());
  DRTStructureSetROISequence& rois = rt.getStructureSetROISequence();
  for (std::size_t i = 0; i < rois.getNumberOfItems(); ++i) {
    Sint32 n = -1;
    rois.getItem(i).getROINumber(n);
    if (n == 5) ASSERT_TRUE(rois.removeItem(i).good());  // the Heart's entry; its contours stay
  }
  ASSERT_TRUE(rt.write(*ff.getDataset()).good());
  ASSERT_TRUE(ff.saveFile(unlisted.c_str(), EXS_LittleEndianExplicit).good());
  const RtStructureSet before = read_rtstruct(kRtss), after = read_rtstruct(unlisted);
  EXPECT_EQ(after.find("Heart"), nullptr);
  ASSERT_EQ(after.unlisted_contours.count(5), 1u);
  EXPECT_EQ(after.unlisted_contours.at(5), int(before.find("Heart")->contours.size()));
  EXPECT_TRUE(before.unlisted_contours.empty());
  std::filesystem::remove_all(dir);
}

// What every reader needs of the written file, read back with DCMTK's own
// parser (not through read_rtstruct): Implicit VR Little Endian, so no
// element comes back as UN, even a ContourData far over Explicit VR's 65,534
// bytes; every DS value within its 16 characters; every contour of at least
// 3 points, its NumberOfContourPoints its data's; the referenced frame of
// reference and series as the input's. The contours: a 4,000-point circle
// (about 120 kB of ContourData), a square with repeated points, and a
// triangle under DS's 0.1 um resolution (not a polygon once written).
constexpr std::size_t kDsMaxChars = 16;  // PS3.5 table 6.2-1

TEST(RtStructWrite, EveryElementKeepsItsVrAndEveryContourItsCount) {
  isoloft::test::TempDir dir;
  const RtStructureSet set = read_rtstruct(kRtss);
  const RtRoi& heart = *set.find("Heart");
  const double z = heart.contours.front().points.front().z();
  RtRoiContours out{&heart, {}};
  RtRoiContours::Plane plane{z, {}};
  std::vector<Vec2d> circle;
  for (int i = 0; i < 4000; ++i) {
    const double a = 2 * M_PI * i / 4000.0;
    circle.emplace_back(-123.456789 + 150.0 * std::cos(a), 234.567891 + 150.0 * std::sin(a));
  }
  plane.loops.push_back(circle);
  plane.loops.push_back({{0, 0}, {0, 0}, {10, 0}, {10, 10}, {10, 10}, {0, 10}, {0, 0}});
  plane.loops.push_back({{5, 5}, {5 + 1e-6, 5}, {5, 5 + 1e-6}});
  out.planes.push_back(plane);
  const std::string path = dir.file("out.dcm");
  write_rtstruct(path, kRtss, {out}, "isoloft test");

  DcmFileFormat ff;
  ASSERT_TRUE(ff.loadFile(path.c_str()).good());
  OFString syntax;
  ASSERT_TRUE(ff.getMetaInfo()->findAndGetOFString(DCM_TransferSyntaxUID, syntax).good());
  EXPECT_EQ(syntax, UID_LittleEndianImplicitTransferSyntax);
  DcmStack stack;
  int elements = 0;
  while (ff.getDataset()->nextObject(stack, OFTrue).good()) {
    auto* e = dynamic_cast<DcmElement*>(stack.top());
    if (!e) continue;
    ++elements;
    EXPECT_NE(e->ident(), EVR_UN) << "element " << e->getTag().toString();
    if (e->ident() != EVR_DS) continue;
    OFString all;  // the values at once (getOFString(value, v) rescans from the start for each v)
    ASSERT_TRUE(e->getOFStringArray(all).good());
    std::size_t v = 0, begin = 0;
    for (std::size_t end = 0; end <= all.size(); ++end) {
      if (end < all.size() && all[end] != '\\') continue;
      EXPECT_LE(end - begin, kDsMaxChars) << "element " << e->getTag().toString() << " value " << v << ": "
                                          << all.substr(begin, end - begin);
      begin = end + 1, ++v;
    }
    EXPECT_EQ(v, e->getVM()) << "element " << e->getTag().toString();
  }
  EXPECT_GT(elements, 40);

  DRTStructureSetIOD rt;
  ASSERT_TRUE(rt.read(*ff.getDataset()).good());
  ASSERT_EQ(rt.getROIContourSequence().getNumberOfItems(), 1u);
  DRTContourSequence& cs = rt.getROIContourSequence().getItem(0).getContourSequence();
  ASSERT_EQ(cs.getNumberOfItems(), 2u) << "the circle and the square; the sub-resolution triangle dropped";
  const std::size_t expect_points[] = {4000, 4};
  for (std::size_t k = 0; k < cs.getNumberOfItems(); ++k) {
    Sint32 count = 0;
    ASSERT_TRUE(cs.getItem(k).getNumberOfContourPoints(count).good());
    OFVector<Float64> data;
    ASSERT_TRUE(cs.getItem(k).getContourData(data).good());
    EXPECT_EQ(std::size_t(count) * 3, data.size()) << "contour " << k;
    EXPECT_EQ(std::size_t(count), expect_points[k]) << "contour " << k;
  }
  DcmElement* big = nullptr;  // the first ContourData in the file: the circle's
  ASSERT_TRUE(ff.getDataset()->findAndGetElement(DCM_ContourData, big, OFTrue).good());
  EXPECT_GT(big->getLength(), 65534u) << "the circle's data must be over Explicit VR's limit to test it";

  // The referenced frame of reference and series: the input's.
  DcmFileFormat src;
  ASSERT_TRUE(src.loadFile(kRtss.c_str()).good());
  DRTStructureSetIOD in;
  ASSERT_TRUE(in.read(*src.getDataset()).good());
  auto series_of = [](DRTStructureSetIOD& s, OFString& frame, OFString& series) {
    auto& frames = s.getReferencedFrameOfReferenceSequence();
    ASSERT_GT(frames.getNumberOfItems(), 0u);
    frames.getItem(0).getFrameOfReferenceUID(frame);
    auto& studies = frames.getItem(0).getRTReferencedStudySequence();
    ASSERT_GT(studies.getNumberOfItems(), 0u);
    auto& series_seq = studies.getItem(0).getRTReferencedSeriesSequence();
    ASSERT_GT(series_seq.getNumberOfItems(), 0u);
    series_seq.getItem(0).getSeriesInstanceUID(series);
  };
  OFString frame_in, series_in, frame_out, series_out;
  series_of(in, frame_in, series_in);
  series_of(rt, frame_out, series_out);
  EXPECT_FALSE(frame_in.empty());
  EXPECT_FALSE(series_in.empty());
  EXPECT_EQ(frame_out, frame_in);
  EXPECT_EQ(series_out, series_in);
  OFString frame_uid;
  rt.getFrameOfReferenceUID(frame_uid);
  EXPECT_EQ(frame_uid, frame_in);
}

// Heart's contours replaced by squares on planes tilted 20 degrees about x,
// written to DICOM and read back: roi_sections (io/rtstruct_sections.h)
// gives one section per tilted plane where roi_stack refuses the oblique ROI.
TEST(RtStruct, TiltedContoursOnDiskBecomeTiltedSections) {
  isoloft::test::TempDir dir;
  const std::string path = dir.file("tilted.dcm");
  const Eigen::Matrix3d tilt = Eigen::AngleAxisd(20 * M_PI / 180, Vec3d::UnitX()).toRotationMatrix();
  std::vector<Contour> contours;
  for (int k = 0; k < 4; ++k) {
    Contour c = square(5, -3, 30 - 4 * k, -100 + 5 * k);
    for (Vec3d& p : c) p = tilt * p;
    contours.push_back(c);
  }
  write_heart_as(path, contours);
  const RtStructureSet set = read_rtstruct(path);
  std::vector<std::string> warnings;
  EXPECT_THROW((void)roi_stack(*set.find("Heart"), RoiGrid{}, path, warnings), InputError);
  const std::vector<Section> sections = roi_sections(*set.find("Heart"), path, warnings);
  ASSERT_EQ(sections.size(), 4u);
  for (std::size_t k = 0; k < 4; ++k) {
    EXPECT_LT((sections[k].pose.normal() - tilt * Vec3d::UnitZ()).norm(), 1e-6) << "section " << k;
    EXPECT_NEAR(sections[k].pose.height(tilt * Vec3d(0, 0, -100 + 5.0 * double(k))), 0, 1e-5) << "section " << k;
    ASSERT_EQ(sections[k].contours.size(), 1u) << "section " << k;
    for (std::size_t i = 0; i < 4; ++i)  // std::to_string's 6 decimals
      EXPECT_LT((sections[k].pose.to_world(sections[k].contours[0].points[i]) - contours[k][i]).norm(), 1e-5)
          << "section " << k << " point " << i;
  }
}
