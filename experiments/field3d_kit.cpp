// Question (issue 35): how close is the field3d surface (one 3D field from
// every section, field3d/field3d.h) to the truth, for sections in any
// orientation? Analytic shapes (sphere, ellipsoid, tilted torus) cut by 5, 10,
// 20 and 40 random planes, an orthogonal triple and a parallel control of 10
// planes; each drawn section is the exact plane section, polygonised at 0.1 mm
// (synth/sections.h). Scored: Chamfer (mean of the two one-sided mean
// distances) and Hausdorff (largest of both sides) as shares of the truth's
// bounding-box diagonal, mesh -> truth by the exact signed distance at area-
// weighted surface samples, truth -> mesh from the truth's points
// (Shape::closest_point of uniform points in its bounds) to the mesh
// (eval/point_mesh.h); the largest per-plane distance between the mesh's
// section and the drawn contour; components, genus, solver iterations, seconds.
// With --csl FILE --ref MESH (the CSL reader, io/csl.h): the same against a reference mesh.
//
// usage: field3d_kit [--out FILE.csv] [--threads N] [--resolution R] [--smoothness S] [--contour-weight W]
//                    [--band B] [--margin M] [--boundary-weight W] [--plane-weight P] [--refinement R] [--refine-width W] [--reweight-passes P] [--reweight-factor F]
//                    [--reweight-tolerance T] [--no-prune] [--plane-signs 0|1] [--plane-sign-distance D]
//                    [--plane-slope 0|1] [--band-per-gap G] [--plane-weight-per-gap W] [--model-resolution M]
//                    [--base-resolution B] [--shape sphere|ellipsoid|torus] [--set random10|orthogonal|...]
//                    [--csl FILE --ref MESH --name NAME [--allow-self-intersections] [--write MESH]]
#include <tbb/global_control.h>

#include <chrono>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <limits>
#include <random>
#include <sstream>

#include "isoloft/eval/point_mesh.h"
#include "isoloft/field3d/field3d.h"
#include "isoloft/io/mesh_io.h"
#include "isoloft/synth/sections.h"
#include "isoloft/io/csl.h"

using namespace isoloft;

namespace {

/// Surface samples per side: the distances' mean is stable to ~1 % at this count.
constexpr int kSamples = 20000;

/// Area-weighted uniform points on the mesh.
std::vector<Vec3d> mesh_samples(const TriMesh& m, int n, unsigned seed) {
  std::vector<double> cum;
  double total = 0;
  for (const auto& t : m.triangles) {
    const Vec3d a = m.vertices[t[0]].cast<double>(), b = m.vertices[t[1]].cast<double>(),
                c = m.vertices[t[2]].cast<double>();
    total += 0.5 * (b - a).cross(c - a).norm();
    cum.push_back(total);
  }
  std::vector<Vec3d> out;
  if (cum.empty()) return out;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  for (int i = 0; i < n; ++i) {
    const auto k = std::size_t(std::lower_bound(cum.begin(), cum.end(), u(rng) * total) - cum.begin());
    const auto& t = m.triangles[std::min(k, m.triangles.size() - 1)];
    double r1 = u(rng), r2 = u(rng);
    if (r1 + r2 > 1) r1 = 1 - r1, r2 = 1 - r2;
    const Vec3d a = m.vertices[t[0]].cast<double>(), b = m.vertices[t[1]].cast<double>(),
                c = m.vertices[t[2]].cast<double>();
    out.push_back(a + r1 * (b - a) + r2 * (c - a));
  }
  return out;
}

struct Score {
  double chamfer = 0, hausdorff = 0;
};

Score score(const std::vector<double>& ab, const std::vector<double>& ba, double diag) {
  const auto mean = [](const std::vector<double>& v) {
    double s = 0;
    for (double x : v) s += x;
    return v.empty() ? 0.0 : s / double(v.size());
  };
  const auto mx = [](const std::vector<double>& v) { return v.empty() ? 0.0 : *std::max_element(v.begin(), v.end()); };
  return {0.5 * (mean(ab) + mean(ba)) / diag, std::max(mx(ab), mx(ba)) / diag};
}

void header(std::ostream& os) {
  os << "shape,set,planes,chamfer,hausdorff,plane_max,components,genus,closed,iterations,residual,grid,seconds,"
        "conflicts,band_unknowns,band_iterations,reweighted,pruned,mesh_to_drawn,drawn_to_mesh,band_nodes,field_nodes,estimate_mib,estimate_band_nodes\n";
}

void row(std::ostream& os, const std::string& shape, const std::string& set, std::size_t planes, const Score& s,
         const Field3dResult& r, double diag, const Field3dWork& w) {
  double pm = 0, md = 0, dm = 0;
  for (const auto& p : r.planes) {
    pm = std::max(pm, p.max());
    md = std::max(md, p.mesh_to_drawn);
    dm = std::max(dm, p.drawn_to_mesh);
  }
  os << shape << ',' << set << ',' << planes << ',' << std::setprecision(5) << s.chamfer << ',' << s.hausdorff << ','
     << pm / diag << ',' << r.check.components << ',' << (2 - r.check.euler) / 2 << ',' << r.check.closed << ','
     << r.iterations << ',' << r.residual << ',' << r.nx << 'x' << r.ny << 'x' << r.nz << ',' << r.seconds << ','
     << r.conflicts.size() << ',' << r.band_unknowns << ',' << r.band_iterations << ',' << r.reweighted << ','
     << r.pruned_components << ',' << md / diag << ',' << dm / diag << ',' << r.band_nodes << ','
     << std::size_t(r.solve_nodes[0]) * std::size_t(r.solve_nodes[1]) * std::size_t(r.solve_nodes[2]) << ','
     << (w.solve_bytes + w.field_bytes + w.mesh_bytes) / (1 << 20) << ',' << w.band_nodes << '\n';
  os.flush();
}


}  // namespace

int main(int argc, char** argv) {
  std::string out = "field3d_kit.csv", csl, ref, name, mesh_out, only_shape, only_set;
  int threads = 2;
  Field3dParams params;
  CslParams csl_params;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const auto next = [&]() -> std::string {
      if (i + 1 >= argc) throw std::runtime_error(a + " needs a value");
      return argv[++i];
    };
    if (a == "--out") out = next();
    else if (a == "--threads") threads = std::stoi(next());
    else if (a == "--resolution") params.resolution = std::stoi(next());
    else if (a == "--smoothness") params.smoothness = std::stod(next());
    else if (a == "--contour-weight") params.contour_weight = std::stod(next());
    else if (a == "--band") params.band = std::stod(next());
    else if (a == "--margin") params.margin = std::stod(next());
    else if (a == "--boundary-weight") params.boundary_weight = std::stod(next());
    else if (a == "--plane-weight") params.plane_weight = std::stod(next());
    else if (a == "--refinement") params.refinement = std::stoi(next());
    else if (a == "--base-resolution") params.base_resolution = std::stoi(next());
    else if (a == "--refine-width") params.refine_width = std::stod(next());
    else if (a == "--reweight-passes") params.reweight_passes = std::stoi(next());
    else if (a == "--reweight-factor") params.reweight_factor = std::stod(next());
    else if (a == "--reweight-tolerance") params.reweight_tolerance = std::stod(next());
    else if (a == "--no-prune") params.prune = false;
    else if (a == "--plane-signs") params.plane_signs = std::stoi(next()) != 0;
    else if (a == "--plane-slope") params.plane_slope = std::stoi(next()) != 0;
    else if (a == "--model-resolution") params.model_resolution = std::stoi(next());
    else if (a == "--band-per-gap") params.band_per_gap = std::stod(next());
    else if (a == "--plane-weight-per-gap") params.plane_weight_per_gap = std::stod(next());
    else if (a == "--plane-sign-distance") params.plane_sign_distance = std::stod(next());
    else if (a == "--write") mesh_out = next();
    else if (a == "--shape") only_shape = next();
    else if (a == "--set") only_set = next();
    else if (a == "--csl") csl = next();
    else if (a == "--ref") ref = next();
    else if (a == "--name") name = next();
    else if (a == "--allow-self-intersections") csl_params.refuse_self_intersections = false;
    else {
      std::cerr << "unknown argument " << a << "\n";
      return 2;
    }
  }
  tbb::global_control gc(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
  std::ofstream os(out);
  header(os);
  header(std::cout);
  if (!csl.empty()) {
    const std::vector<Section> sections = read_csl(csl, csl_params).sections;
    const Field3dResult r = reconstruct_sections(sections, 1, params);
    if (!mesh_out.empty()) write_mesh(mesh_out, r.mesh);
    // Without a reference (armadillo: none stored) only the run's own figures; shares of the mesh's diagonal.
    const TriMesh reference = ref.empty() ? r.mesh : read_mesh(ref);
    Vec3d lo = Vec3d::Constant(1e300), hi = Vec3d::Constant(-1e300);
    for (const Vec3f& v : reference.vertices) lo = lo.cwiseMin(v.cast<double>()), hi = hi.cwiseMax(v.cast<double>());
    const double diag = (hi - lo).norm();
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const Score s = ref.empty() ? Score{nan, nan}
                                : score(point_mesh_distances(reference, mesh_samples(r.mesh, kSamples, 1)),
                                        point_mesh_distances(r.mesh, mesh_samples(reference, kSamples, 2)), diag);
    for (std::ostream* o : {static_cast<std::ostream*>(&os), static_cast<std::ostream*>(&std::cout)})
      row(*o, name.empty() ? csl : name, "csl", sections.size(), s, r, diag, estimate_sections(sections, 1, params));
    for (const auto& w : r.warnings) std::cerr << "warning: " << w << "\n";
    return 0;
  }
  const std::vector<std::pair<std::string, nlohmann::json>> shapes{
      {"sphere", {{"type", "sphere"}, {"center", {0, 0, 0}}, {"radius", 30}}},
      {"ellipsoid", {{"type", "ellipsoid"}, {"center", {0, 0, 0}}, {"radii", {36, 24, 16}}}},
      {"torus", {{"type", "torus"}, {"center", {0, 0, 0}}, {"major_radius", 30}, {"minor_radius", 12}, {"tilt_deg", 30}}},
  };
  for (const auto& [sname, js] : shapes) {
    if (!only_shape.empty() && sname != only_shape) continue;
    const auto shape = shape_from_json(js);
    const auto [lo, hi] = shape->bounds();
    const double diag = (hi - lo).norm();
    std::vector<std::pair<std::string, std::vector<PlanePose>>> sets;
    for (int n : {5, 10, 20, 40}) sets.emplace_back("random" + std::to_string(n), random_poses(*shape, n, 100u + n));
    sets.emplace_back("orthogonal", orthogonal_poses(*shape));
    sets.emplace_back("parallel10", parallel_poses(*shape, 10));
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(0, 1);
    std::vector<Vec3d> truth;
    for (int i = 0; i < kSamples; ++i) truth.push_back(shape->closest_point(lo + (hi - lo).cwiseProduct(Vec3d(u(rng), u(rng), u(rng)))));
    for (const auto& [set, poses] : sets) {
      if (!only_set.empty() && set != only_set) continue;
      const std::vector<Section> sections = analytic_sections(*shape, poses, 0.1);
      const Field3dResult r = reconstruct_sections(sections, 1, params);
      std::vector<double> ab;
      for (const Vec3d& p : mesh_samples(r.mesh, kSamples, 1)) ab.push_back(shape->distance(p));
      const Score s = score(ab, point_mesh_distances(r.mesh, truth), diag);
      for (std::ostream* o : {static_cast<std::ostream*>(&os), static_cast<std::ostream*>(&std::cout)})
        row(*o, sname, set, poses.size(), s, r, diag, estimate_sections(sections, 1, params));
    }
  }
  return 0;
}
