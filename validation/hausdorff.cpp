// CGAL Hausdorff oracles (see hausdorff.h).
#include "validation/hausdorff.h"

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/distance.h>
#include <CGAL/Surface_mesh.h>
#include <Eigen/Geometry>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <string>

#include "isoloft/core/error.h"

namespace isoloft {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point3 = K::Point_3;
using Triangle3 = K::Triangle_3;
using SurfaceMesh = CGAL::Surface_mesh<Point3>;
using TriangleVector = std::vector<Triangle3>;
using Primitive = CGAL::AABB_triangle_primitive<K, TriangleVector::const_iterator>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<K, Primitive>>;
namespace PMP = CGAL::Polygon_mesh_processing;

constexpr double kSqrt3 = 1.73205080756887729353;

Point3 point(const Vec3f& v) { return Point3(v.x(), v.y(), v.z()); }
Point3 point(const Vec3d& v) { return Point3(v.x(), v.y(), v.z()); }

void check_mesh(const TriMesh& m, const char* fn, const char* name) {
  const std::string where = std::string(fn) + ": mesh " + name;
  if (m.triangles.empty()) throw InputError("", where + " has no triangles");
  for (std::size_t i = 0; i < m.vertices.size(); ++i)
    if (!m.vertices[i].allFinite()) throw InputError("", where + " vertex " + std::to_string(i) + " is not finite");
  for (std::size_t t = 0; t < m.triangles.size(); ++t)
    for (const auto v : m.triangles[t])
      if (v < 0 || std::size_t(v) >= m.vertices.size())
        throw InputError("", where + " triangle " + std::to_string(t) + " has vertex index " + std::to_string(v) +
                                 " out of range");
}

void check_sampling(const MeshSamplingParams& s, const char* fn) {
  if (!(s.spacing > 0) || !std::isfinite(s.spacing)) throw ParamError(std::string(fn) + ": sampling spacing must be > 0");
  if (s.max_samples < 1) throw ParamError(std::string(fn) + ": max_samples must be >= 1");
}

TriangleVector triangles_of(const TriMesh& m) {
  TriangleVector tris;
  tris.reserve(m.triangles.size());
  for (const auto& t : m.triangles)
    tris.emplace_back(point(m.vertices[t[0]]), point(m.vertices[t[1]]), point(m.vertices[t[2]]));
  return tris;
}

// Welded where the triangles form a valid halfedge structure; a triangle that
// does not (non-manifold, repeated index, inconsistent orientation) becomes a
// separate piece with its own copies of its vertices: the point set, which is
// all the Hausdorff distance sees, is unchanged.
SurfaceMesh to_surface_mesh(const TriMesh& m) {
  SurfaceMesh sm;
  std::vector<SurfaceMesh::Vertex_index> vs;
  vs.reserve(m.vertices.size());
  for (const auto& v : m.vertices) vs.push_back(sm.add_vertex(point(v)));
  for (const auto& t : m.triangles) {
    if (t[0] != t[1] && t[1] != t[2] && t[0] != t[2] &&
        sm.add_face(vs[t[0]], vs[t[1]], vs[t[2]]) != SurfaceMesh::null_face())
      continue;
    sm.add_face(sm.add_vertex(point(m.vertices[t[0]])), sm.add_vertex(point(m.vertices[t[1]])),
                sm.add_vertex(point(m.vertices[t[2]])));
  }
  return sm;
}

// AABB tree ready for concurrent distance queries: the search structure is
// built lazily on the first query, so make that one here.
void prepare(Tree& tree) {
  tree.build();
  tree.accelerate_distance_queries();
  (void)tree.squared_distance(Point3(0, 0, 0));
}

// Samples' distances to a tree; the interval [max d, max (d + r)].
std::vector<double> distances_to(const Tree& tree, const std::vector<Vec3d>& pts) {
  std::vector<double> d(pts.size());
  tbb::parallel_for(std::size_t(0), pts.size(), [&](std::size_t i) { d[i] = std::sqrt(tree.squared_distance(point(pts[i]))); });
  return d;
}

HausdorffInterval sampled_interval(const std::vector<double>& d, const std::vector<double>& r) {
  HausdorffInterval h;
  for (std::size_t i = 0; i < d.size(); ++i) {
    h.lower = std::max(h.lower, d[i]);
    h.upper = std::max(h.upper, d[i] + r[i]);
  }
  return h;
}

double bbox_scale(const TriMesh& a, const TriMesh& b) {
  double s = 0;
  for (const auto* m : {&a, &b})
    for (const auto& v : m->vertices) s = std::max(s, double(v.cwiseAbs().maxCoeff()));
  return s;
}

// Selected entries of values/weights/radius summarised as DirectedStats.
DirectedStats directed(const std::vector<double>& d, const std::vector<double>& w, const std::vector<double>& r,
                       const std::vector<char>& select) {
  DirectedStats s;
  std::vector<double> dv, wv;
  for (std::size_t i = 0; i < d.size(); ++i) {
    if (!select[i]) continue;
    s.max.lower = std::max(s.max.lower, d[i]);
    s.max.upper = std::max(s.max.upper, d[i] + r[i]);
    if (w[i] > 0) {
      dv.push_back(d[i]);
      wv.push_back(w[i]);
      s.weight += w[i];
      ++s.samples;
    }
  }
  std::tie(s.mean, s.p99) = detail::weighted_mean_p99(dv, wv);
  return s;
}

}  // namespace

std::vector<double> point_to_mesh_distances(const TriMesh& mesh, const std::vector<Vec3d>& points) {
  check_mesh(mesh, "point_to_mesh_distances", "");
  const TriangleVector tris = triangles_of(mesh);
  Tree tree(tris.begin(), tris.end());
  tree.accelerate_distance_queries();
  std::vector<double> d(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) d[i] = std::sqrt(tree.squared_distance(point(points[i])));
  return d;
}

// ---- CGAL-free parts --------------------------------------------------------

namespace detail {

std::pair<double, double> weighted_mean_p99(const std::vector<double>& values, const std::vector<double>& weights) {
  if (values.empty()) return {0.0, 0.0};
  double total = 0;
  for (const double w : weights) total += w;
  const bool equal = !(total > 0);
  if (equal) total = double(values.size());
  double mean = 0;
  for (std::size_t i = 0; i < values.size(); ++i) mean += (equal ? 1.0 : weights[i]) * values[i];
  mean /= total;
  std::vector<std::size_t> order(values.size());
  std::iota(order.begin(), order.end(), std::size_t(0));
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return values[a] < values[b]; });
  double acc = 0, p99 = values[order.back()];
  for (const std::size_t i : order) {
    acc += equal ? 1.0 : weights[i];
    if (acc >= 0.99 * total) {
      p99 = values[i];
      break;
    }
  }
  return {mean, p99};
}

MeshSamples sample_mesh(const TriMesh& mesh, double spacing, long max_samples) {
  auto subdivisions = [&](double s) {
    std::vector<int> n(mesh.triangles.size());
    long total = 0;
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
      const auto& tri = mesh.triangles[t];
      const Vec3d a = mesh.vertices[tri[0]].cast<double>(), b = mesh.vertices[tri[1]].cast<double>(),
                  c = mesh.vertices[tri[2]].cast<double>();
      const double longest = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
      n[t] = std::max(1, int(std::ceil(longest / s)));
      total += long(n[t]) * n[t];
    }
    return std::make_pair(n, total);
  };
  auto [n, total] = subdivisions(spacing);
  while (total + long(mesh.vertices.size()) > max_samples && total > long(mesh.triangles.size())) {
    spacing *= std::sqrt(double(total) / double(std::max(1L, max_samples - long(mesh.vertices.size())))) * 1.05;
    std::tie(n, total) = subdivisions(spacing);
  }
  MeshSamples s;
  s.spacing = spacing;
  s.points.reserve(std::size_t(total) + mesh.vertices.size());
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& tri = mesh.triangles[t];
    const Vec3d a = mesh.vertices[tri[0]].cast<double>(), b = mesh.vertices[tri[1]].cast<double>(),
                c = mesh.vertices[tri[2]].cast<double>();
    const int k = n[t];
    const Vec3d u = (b - a) / k, v = (c - a) / k;
    const double sub_area = 0.5 * (b - a).cross(c - a).norm() / (double(k) * k);
    // Every sub-triangle is a translate of (0, u, v) or of its point reflection.
    const Vec3d g = (u + v) / 3.0;
    const double radius = std::max({g.norm(), (u - g).norm(), (v - g).norm()});
    for (int i = 0; i < k; ++i)
      for (int j = 0; i + j < k; ++j) {
        const Vec3d o = a + double(i) * u + double(j) * v;
        s.points.push_back(o + g);  // up: o, o + u, o + v
        if (i + j + 1 < k) s.points.push_back(o + u + v - g);  // down: o + u, o + v, o + u + v
      }
    const std::size_t added = s.points.size() - s.weights.size();
    s.weights.insert(s.weights.end(), added, sub_area);
    s.radius.insert(s.radius.end(), added, radius);
    s.face.insert(s.face.end(), added, int(t));
  }
  for (const auto& v : mesh.vertices) {
    s.points.push_back(v.cast<double>());
    s.weights.push_back(0.0);
    s.radius.push_back(0.0);
    s.face.push_back(-1);
  }
  return s;
}

HausdorffInterval hausdorff_naive(const TriMesh& a, const TriMesh& b, double spacing) {
  check_mesh(a, "hausdorff_naive", "a");
  check_mesh(b, "hausdorff_naive", "b");
  const MeshSamples s = sample_mesh(a, spacing, std::numeric_limits<long>::max());
  const TriangleVector tris = triangles_of(b);
  std::vector<double> d(s.points.size());
  tbb::parallel_for(std::size_t(0), s.points.size(), [&](std::size_t i) {
    const Point3 p = point(s.points[i]);
    double best = std::numeric_limits<double>::infinity();
    for (const auto& t : tris) best = std::min(best, CGAL::squared_distance(p, t));
    d[i] = std::sqrt(best);
  });
  return sampled_interval(d, s.radius);
}

}  // namespace detail

HausdorffInterval MeshDistanceReport::symmetric() const {
  return {std::max(a_to_b.lower, b_to_a.lower), std::max(a_to_b.upper, b_to_a.upper)};
}

nlohmann::json MeshDistanceReport::to_json() const {
  return {{"a_to_b", a_to_b.to_json()},       {"b_to_a", b_to_a.to_json()},
          {"symmetric", symmetric().to_json()}, {"cgal_a_to_b_px", cgal_a_to_b},
          {"cgal_b_to_a_px", cgal_b_to_a},     {"mean_a_to_b_px", mean_a_to_b},
          {"mean_b_to_a_px", mean_b_to_a},     {"p99_a_to_b_px", p99_a_to_b},
          {"p99_b_to_a_px", p99_b_to_a},       {"samples_a", samples_a},
          {"samples_b", samples_b}};
}

nlohmann::json DirectedStats::to_json() const {
  return {{"mean_px", mean}, {"p99_px", p99}, {"max", max.to_json()}, {"weight", weight}, {"samples", samples}};
}

nlohmann::json TruthRegionStats::to_json() const {
  return {{"mesh_to_truth", mesh_to_truth.to_json()},
          {"truth_to_mesh", truth_to_mesh.to_json()},
          {"mean_normal_angle_deg", mean_normal_angle_deg}};
}

nlohmann::json TruthDistanceReport::to_json() const {
  return {{"in_range", in_range.to_json()},
          {"caps", caps.to_json()},
          {"hausdorff", hausdorff.to_json()},
          {"truth_spacing_px", truth_spacing}};
}

Verdict hausdorff_verdict(const HausdorffInterval& h, double threshold) {
  if (h.upper <= threshold) return Verdict::Pass;
  if (h.lower > threshold) return Verdict::Fail;
  return Verdict::Undecided;
}

const char* to_string(Verdict v) {
  switch (v) {
    case Verdict::Pass: return "pass";
    case Verdict::Fail: return "fail";
    case Verdict::Undecided: return "undecided";
  }
  return "?";
}

// ---- mesh vs mesh -----------------------------------------------------------

MeshDistanceReport mesh_distance(const TriMesh& a, const TriMesh& b, double error_bound,
                                 const MeshSamplingParams& sampling) {
  check_mesh(a, "mesh_distance", "a");
  check_mesh(b, "mesh_distance", "b");
  if (!(error_bound > 0) || !std::isfinite(error_bound))
    throw ParamError("mesh_distance: error_bound must be > 0 (got " + std::to_string(error_bound) + ")");
  check_sampling(sampling, "mesh_distance");
  // Double rounding in CGAL's and our distance evaluations (relative ~1e-15
  // of the coordinates); 1e-9 of the scale covers it with a wide margin.
  const double slack = 1e-9 * (1.0 + bbox_scale(a, b));

  MeshDistanceReport r;
  const SurfaceMesh sa = to_surface_mesh(a), sb = to_surface_mesh(b);
  r.cgal_a_to_b = PMP::bounded_error_Hausdorff_distance<CGAL::Sequential_tag>(sa, sb, error_bound);
  r.cgal_b_to_a = PMP::bounded_error_Hausdorff_distance<CGAL::Sequential_tag>(sb, sa, error_bound);

  const TriangleVector ta = triangles_of(a), tb = triangles_of(b);
  Tree tree_a(ta.begin(), ta.end()), tree_b(tb.begin(), tb.end());
  prepare(tree_a);
  prepare(tree_b);

  auto one_side = [&](const TriMesh& from, const Tree& to, double cgal, HausdorffInterval& h, double& mean,
                      double& p99, long& samples) {
    const detail::MeshSamples s = detail::sample_mesh(from, sampling.spacing, sampling.max_samples);
    const std::vector<double> d = distances_to(to, s.points);
    const HausdorffInterval sampled = sampled_interval(d, s.radius);
    // |cgal - H| <= error_bound (CGAL's contract) and the sampling bound.
    h.lower = std::max(cgal - error_bound, sampled.lower) - slack;
    h.upper = std::min(cgal + error_bound, sampled.upper) + slack;
    h.lower = std::max(0.0, h.lower);
    std::tie(mean, p99) = detail::weighted_mean_p99(d, s.weights);
    samples = long(s.points.size() - from.vertices.size());
  };
  one_side(a, tree_b, r.cgal_a_to_b, r.a_to_b, r.mean_a_to_b, r.p99_a_to_b, r.samples_a);
  one_side(b, tree_a, r.cgal_b_to_a, r.b_to_a, r.mean_b_to_a, r.p99_b_to_a, r.samples_b);
  return r;
}

// ---- mesh vs analytic shape ---------------------------------------------------

namespace {

// Surface samples by hierarchical voxels. A voxel (centre g, side h) can hold
// a surface point only if |value(g)| <= (sqrt(3) / 2) h, since |value| <= the
// distance to the surface (value is 1-Lipschitz: exact for sphere and torus,
// and for the ellipsoid and smooth-max blends of synth/shapes.h too). Kept
// voxels are split in 8 down to `h` (growing h while the next level would pass
// the cap); the final centres are projected by closest_point. Every surface
// point lies in a kept final voxel, so it is within sqrt(3) h of a sample.
}  // namespace

namespace detail {

std::vector<Vec3d> sample_shape_surface(const Shape& shape, double& h, long max_samples) {
  const double target = h;
  constexpr double kCoarse = 4.0;  // px: first level, cheap to evaluate over the whole box
  int levels = 0;
  while (target * double(1 << levels) < kCoarse && levels < 20) ++levels;
  h = target * double(1 << levels);
  const double keep = 0.5 * kSqrt3 * (1.0 + 1e-12);
  const auto bounds = shape.bounds();
  const Vec3d lo = bounds[0] - Vec3d::Constant(h), hi = bounds[1] + Vec3d::Constant(h);
  const Eigen::Vector3i n = ((hi - lo) / h).array().ceil().cast<int>() + 1;
  std::vector<std::vector<Vec3d>> slab(std::size_t(n.z()));
  tbb::parallel_for(0, n.z(), [&](int k) {
    for (int j = 0; j < n.y(); ++j)
      for (int i = 0; i < n.x(); ++i) {
        const Vec3d g = lo + h * Vec3d(i, j, k);
        if (std::abs(shape.value(g)) <= keep * h) slab[std::size_t(k)].push_back(g);
      }
  });
  std::vector<Vec3d> voxels;
  for (const auto& s : slab) voxels.insert(voxels.end(), s.begin(), s.end());
  // A surface's voxel count grows ~4x per halving.
  for (; levels > 0 && 4 * long(voxels.size()) <= max_samples; --levels) {
    const double child = 0.5 * h;
    constexpr std::size_t kBlock = 4096;
    std::vector<std::vector<Vec3d>> out((voxels.size() + kBlock - 1) / kBlock);
    tbb::parallel_for(std::size_t(0), out.size(), [&](std::size_t b) {
      for (std::size_t v = b * kBlock; v < std::min(voxels.size(), (b + 1) * kBlock); ++v)
        for (int c = 0; c < 8; ++c) {
          const Vec3d g = voxels[v] + 0.5 * child * Vec3d(c & 1 ? 1 : -1, c & 2 ? 1 : -1, c & 4 ? 1 : -1);
          if (std::abs(shape.value(g)) <= keep * child) out[b].push_back(g);
        }
    });
    voxels.clear();
    for (const auto& o : out) voxels.insert(voxels.end(), o.begin(), o.end());
    h = child;
  }
  tbb::parallel_for(std::size_t(0), voxels.size(), [&](std::size_t i) { voxels[i] = shape.closest_point(voxels[i]); });
  return voxels;
}

}  // namespace detail

TruthDistanceReport mesh_to_truth(const TriMesh& mesh, const Shape& truth, double z_first, double z_last,
                                  const TruthDistanceParams& params) {
  check_mesh(mesh, "mesh_to_truth", "");
  check_sampling(params.mesh, "mesh_to_truth");
  if (!(params.truth_spacing > 0) || !std::isfinite(params.truth_spacing))
    throw ParamError("mesh_to_truth: truth_spacing must be > 0");
  if (params.max_truth_samples < 1) throw ParamError("mesh_to_truth: max_truth_samples must be >= 1");
  if (!(z_first <= z_last)) throw ParamError("mesh_to_truth: z_first must be <= z_last");
  auto in_range = [&](const Vec3d& p) { return p.z() >= z_first && p.z() <= z_last; };

  TruthDistanceReport r;
  // Mesh -> truth.
  const detail::MeshSamples s = detail::sample_mesh(mesh, params.mesh.spacing, params.mesh.max_samples);
  std::vector<double> d(s.points.size()), angle(s.points.size(), 0.0);
  std::vector<Vec3d> face_normal(mesh.triangles.size());
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& tri = mesh.triangles[t];
    const Vec3d a = mesh.vertices[tri[0]].cast<double>(), b = mesh.vertices[tri[1]].cast<double>(),
                c = mesh.vertices[tri[2]].cast<double>();
    const Vec3d n = (b - a).cross(c - a);
    face_normal[t] = n.norm() > 0 ? Vec3d(n.normalized()) : Vec3d::Zero();
  }
  tbb::parallel_for(std::size_t(0), s.points.size(), [&](std::size_t i) {
    const Vec3d foot = truth.closest_point(s.points[i]);
    d[i] = (foot - s.points[i]).norm();
    if (s.face[i] >= 0) {
      const double c = std::clamp(face_normal[std::size_t(s.face[i])].dot(truth.normal(foot)), -1.0, 1.0);
      angle[i] = std::acos(c) * 180.0 / M_PI;
    }
  });
  std::vector<char> sel_in(s.points.size()), sel_caps(s.points.size());
  for (std::size_t i = 0; i < s.points.size(); ++i) sel_caps[i] = !(sel_in[i] = in_range(s.points[i]));
  r.in_range.mesh_to_truth = directed(d, s.weights, s.radius, sel_in);
  r.caps.mesh_to_truth = directed(d, s.weights, s.radius, sel_caps);
  auto mean_angle = [&](const std::vector<char>& sel) {
    double sw = 0, sa = 0;
    for (std::size_t i = 0; i < angle.size(); ++i)
      if (sel[i]) {
        sw += s.weights[i];
        sa += s.weights[i] * angle[i];
      }
    return sw > 0 ? sa / sw : 0.0;
  };
  r.in_range.mean_normal_angle_deg = mean_angle(sel_in);
  r.caps.mean_normal_angle_deg = mean_angle(sel_caps);

  // Truth -> mesh.
  double h = params.truth_spacing;
  const std::vector<Vec3d> tp = detail::sample_shape_surface(truth, h, params.max_truth_samples);
  r.truth_spacing = h;
  const TriangleVector tris = triangles_of(mesh);
  Tree tree(tris.begin(), tris.end());
  prepare(tree);
  const std::vector<double> td = distances_to(tree, tp);
  const std::vector<double> tw(tp.size(), 1.0), tr(tp.size(), kSqrt3 * h);
  std::vector<char> tin(tp.size()), tcaps(tp.size());
  for (std::size_t i = 0; i < tp.size(); ++i) tcaps[i] = !(tin[i] = in_range(tp[i]));
  r.in_range.truth_to_mesh = directed(td, tw, tr, tin);
  r.caps.truth_to_mesh = directed(td, tw, tr, tcaps);

  for (const auto* st : {&r.in_range.mesh_to_truth, &r.caps.mesh_to_truth, &r.in_range.truth_to_mesh,
                         &r.caps.truth_to_mesh}) {
    r.hausdorff.lower = std::max(r.hausdorff.lower, st->max.lower);
    r.hausdorff.upper = std::max(r.hausdorff.upper, st->max.upper);
  }
  return r;
}

}  // namespace isoloft
