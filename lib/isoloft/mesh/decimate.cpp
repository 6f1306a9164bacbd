#include "isoloft/mesh/decimate.h"

#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
// QuadricT.hh needs vector_traits from the mesh headers: keep it after them.
#include <OpenMesh/Core/Geometry/QuadricT.hh>
#include <OpenMesh/Tools/Decimater/DecimaterT.hh>
#include <OpenMesh/Tools/Decimater/ModBaseT.hh>
#include <OpenMesh/Tools/Decimater/ModNormalFlippingT.hh>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "isoloft/core/error.h"

namespace isoloft {

namespace detail {
namespace {

struct OmTraits : OpenMesh::DefaultTraits {
  using Point = OpenMesh::Vec3d;  // double: the error test must not lose to float rounding
  using Normal = OpenMesh::Vec3d;
  VertexAttributes(OpenMesh::Attributes::Status);
  EdgeAttributes(OpenMesh::Attributes::Status);
  FaceAttributes(OpenMesh::Attributes::Status | OpenMesh::Attributes::Normal);
};

// OpenMesh's mesh with two hot connectivity queries compiled here instead of
// called in libOpenMeshCore: Debian's build keeps its assertions, and every
// property access there compares type-name strings, which made these two
// calls ~60% of the decimation time. DecimaterT calls them through the mesh
// type, so these hide the library versions.
struct OmMesh : OpenMesh::TriMesh_ArrayKernelT<OmTraits> {
  /// Same test as OpenMesh's TriConnectivity::is_collapse_ok: collapsing
  /// v0 -> v1 keeps a manifold iff the one-rings of v0 and v1 share only the
  /// opposite vertices vl, vr (link condition), no face with two boundary
  /// edges would be squashed, and an interior edge does not join two boundary
  /// vertices.
  bool is_collapse_ok(HalfedgeHandle v0v1) {
    if (status(edge_handle(v0v1)).deleted()) return false;
    const HalfedgeHandle v1v0 = opposite_halfedge_handle(v0v1);
    const VertexHandle v0 = to_vertex_handle(v1v0), v1 = to_vertex_handle(v0v1);
    if (status(v0).deleted() || status(v1).deleted()) return false;
    VertexHandle vl, vr;
    for (auto [h, side] : {std::pair{v0v1, &vl}, std::pair{v1v0, &vr}}) {
      if (is_boundary(h)) continue;
      const HalfedgeHandle h1 = next_halfedge_handle(h), h2 = next_halfedge_handle(h1);
      *side = to_vertex_handle(h1);
      if (is_boundary(opposite_halfedge_handle(h1)) && is_boundary(opposite_halfedge_handle(h2))) return false;
    }
    if (vl == vr) return false;
    ring_.clear();
    for (VertexHandle w : vv_range(v1)) ring_.push_back(w);
    for (VertexHandle w : vv_range(v0))
      if (w != vl && w != vr && std::find(ring_.begin(), ring_.end(), w) != ring_.end()) return false;
    return !(is_boundary(v0) && is_boundary(v1) && !is_boundary(v0v1) && !is_boundary(v1v0));
  }
  HalfedgeHandle find_halfedge(VertexHandle from, VertexHandle to) const {
    for (HalfedgeHandle h : voh_range(from))
      if (to_vertex_handle(h) == to) return h;
    return HalfedgeHandle();
  }

 private:
  std::vector<VertexHandle> ring_;
};
using OmPoint = OmMesh::Point;

// A triangle prepared for many squared-distance queries; exact also for
// zero-area triangles (then the distance to the nearest side).
struct PreparedTriangle {
  OmPoint a, b, c, ab, bc, ca, n, in_ab, in_bc, in_ca;
  double n2, inv_ab2, inv_bc2, inv_ca2;

  PreparedTriangle(const OmPoint& a_, const OmPoint& b_, const OmPoint& c_)
      : a(a_), b(b_), c(c_), ab(b - a), bc(c - b), ca(a - c), n(ab % (c - a)) {
    n2 = n.sqrnorm();
    in_ab = n % ab, in_bc = n % bc, in_ca = n % ca;  // point into the triangle
    auto inv = [](const OmPoint& e) { return e.sqrnorm() > 0 ? 1.0 / e.sqrnorm() : 0.0; };
    inv_ab2 = inv(ab), inv_bc2 = inv(bc), inv_ca2 = inv(ca);
  }

  [[nodiscard]] double distance_sq(const OmPoint& p) const {
    const OmPoint pa = p - a, pb = p - b, pc = p - c;
    if (n2 > 0 && (pa | in_ab) >= 0 && (pb | in_bc) >= 0 && (pc | in_ca) >= 0) {
      const double h = pa | n;  // projection inside: distance to the plane
      return h * h / n2;
    }
    auto segment = [](const OmPoint& q, const OmPoint& e, double inv_len2) {  // q relative to the segment start
      const double t = std::clamp((q | e) * inv_len2, 0.0, 1.0);
      return (q - t * e).sqrnorm();
    };
    return std::min({segment(pa, ab, inv_ab2), segment(pb, bc, inv_bc2), segment(pc, ca, inv_ca2)});
  }
};

// The Decimater's one continuous module: Garland-Heckbert priority (the
// area-weighted plane quadrics of OpenMesh's ModQuadricT) with the error bound
// as a hard constraint. Bound scheme as OpenMesh's ModHausdorffT: every
// removed vertex is stored with its nearest face and re-tested whenever that
// face changes. Differences, see decimate.h: points go only to the faces that
// were around v0 (whose vertices the Decimater re-queues), zero-area faces get
// their true distance, and the test runs lazily: DecimaterT::heap_vertex()
// evaluates all halfedges out of one vertex in a row and keeps the smallest
// priority, so a candidate whose quadric error is not below the best legal
// one so far for that vertex cannot be chosen and needs no test.
template <class MeshT>
class ModBoundedQuadricT : public OpenMesh::Decimater::ModBaseT<MeshT> {
 public:
  DECIMATING_MODULE(ModBoundedQuadricT, MeshT, BoundedQuadric);
  using Points = std::vector<OmPoint>;
  using FaceHandle = typename MeshT::FaceHandle;
  using VertexHandle = typename MeshT::VertexHandle;
  using Quadric = OpenMesh::Geometry::QuadricT<double>;

  explicit ModBoundedQuadricT(MeshT& mesh) : Base(mesh, false) {
    mesh.add_property(points_);
    mesh.add_property(quadrics_);
  }
  ~ModBoundedQuadricT() override {
    Base::mesh().remove_property(points_);
    Base::mesh().remove_property(quadrics_);
  }
  void set_tolerance(double tolerance) { tolerance_ = tolerance; }

  void initialize() override {
    MeshT& m = Base::mesh();
    for (auto v : m.vertices()) m.property(quadrics_, v).clear();
    for (auto f : m.faces()) {
      m.property(points_, f).clear();
      auto fv = m.cfv_iter(f);
      const VertexHandle a = *fv, b = *++fv, c = *++fv;
      OmPoint n = (m.point(b) - m.point(a)) % (m.point(c) - m.point(a));
      const double twice_area = n.norm();
      if (twice_area <= 0) continue;  // no plane; contributes nothing
      n /= twice_area;
      Quadric q(n[0], n[1], n[2], -(m.point(a) | n));
      q *= 0.5 * twice_area;
      for (VertexHandle v : {a, b, c}) m.property(quadrics_, v) += q;
    }
    sequence_v0_.reset();
  }

  float collapse_priority(const CollapseInfo& ci) override {
    MeshT& m = Base::mesh();
    Quadric q = m.property(quadrics_, ci.v0);
    q += m.property(quadrics_, ci.v1);
    const double err = std::max(0.0, q(ci.p1));  // >= 0 up to rounding
    if (ci.v0 != sequence_v0_) sequence_v0_ = ci.v0, sequence_best_ = std::numeric_limits<double>::infinity();
    if (err >= sequence_best_) return float(err);  // cannot win: skip the bound test
    if (!within_tolerance(ci)) return float(Base::ILLEGAL_COLLAPSE);
    sequence_best_ = err;
    return float(err);
  }

  // Takes the points out of the faces around v0; collapse_priority() has just
  // accepted this collapse, so faces_ and tris_ describe it.
  void preprocess_collapse(const CollapseInfo& ci) override {
    prepare(ci);
    moved_.clear();
    for (auto [f, own] : around_) {
      Points& stored = Base::mesh().property(points_, f);
      moved_.insert(moved_.end(), stored.begin(), stored.end());
      stored.clear();
    }
    moved_.push_back(ci.p0);
  }

  // The faces that were around v0 (but fl, fr) now have v1 instead; each
  // point goes to its nearest one, within tolerance by within_tolerance().
  void postprocess_collapse(const CollapseInfo& ci) override {
    MeshT& m = Base::mesh();
    m.property(quadrics_, ci.v1) += m.property(quadrics_, ci.v0);
    sequence_v0_.reset();  // a new heap_vertex() sequence starts
    if (faces_.empty()) return;  // unreachable: within_tolerance() rejects it
    for (const OmPoint& p : moved_) {
      std::size_t best = 0;
      double best_d = std::numeric_limits<double>::infinity();
      for (std::size_t k = 0; k < tris_.size(); ++k) {
        const double d = tris_[k].distance_sq(p);
        if (d < best_d) best_d = d, best = k;
      }
      m.property(points_, faces_[best]).push_back(p);
    }
  }

 private:
  // Every point stored around v0, plus v0 itself, must be within tolerance of
  // one of the faces around v0 but fl, fr after v0 moves to p1. Each point is
  // first tested against the face that holds it (usually enough).
  bool within_tolerance(const CollapseInfo& ci) {
    prepare(ci);
    const double tol2 = tolerance_ * tolerance_;
    auto near_any = [&](const OmPoint& p, int skip) {
      for (std::size_t k = 0; k < tris_.size(); ++k)
        if (int(k) != skip && tris_[k].distance_sq(p) <= tol2) return true;
      return false;
    };
    for (auto [f, own] : around_)
      for (const OmPoint& p : Base::mesh().property(points_, f))
        if (!(own >= 0 && tris_[std::size_t(own)].distance_sq(p) <= tol2) && !near_any(p, own)) return false;
    return near_any(ci.p0, -1);
  }

  // around_: every face around v0 with the index of its surviving version in
  // faces_/tris_ (-1 for fl, fr); tris_: those faces with v0 moved to p1.
  void prepare(const CollapseInfo& ci) {
    MeshT& m = Base::mesh();
    faces_.clear();
    tris_.clear();
    around_.clear();
    for (auto f : m.vf_range(ci.v0)) {
      int own = -1;
      if (f != ci.fl && f != ci.fr) {
        own = int(faces_.size());
        faces_.push_back(f);
        std::array<OmPoint, 3> t;
        int k = 0;
        for (auto v : m.fv_range(f)) t[std::size_t(k++)] = v == ci.v0 ? ci.p1 : m.point(v);
        tris_.emplace_back(t[0], t[1], t[2]);
      }
      around_.emplace_back(f, own);
    }
  }

  double tolerance_ = 0.0;
  OpenMesh::FPropHandleT<Points> points_;
  OpenMesh::VPropHandleT<Quadric> quadrics_;
  VertexHandle sequence_v0_;
  double sequence_best_ = 0.0;
  std::vector<FaceHandle> faces_;
  std::vector<PreparedTriangle> tris_;
  std::vector<std::pair<FaceHandle, int>> around_;
  Points moved_;
};

}  // namespace
}  // namespace detail

DecimateResult decimate(TriMesh& mesh, const DecimateParams& params) {
  if (!std::isfinite(params.max_error) || params.max_error < 0)
    throw ParamError("decimate: max_error = " + std::to_string(params.max_error) + " must be finite and >= 0 (pixels)");
  if (!(params.max_normal_deviation_deg > 0 && params.max_normal_deviation_deg < 90))
    throw ParamError("decimate: max_normal_deviation_deg = " + std::to_string(params.max_normal_deviation_deg) +
                     " must be in (0, 90)");
  const std::size_t nv = mesh.vertices.size(), nf = mesh.triangles.size();
  for (std::size_t f = 0; f < nf; ++f) {
    const auto& t = mesh.triangles[f];
    for (std::int32_t v : t)
      if (v < 0 || std::size_t(v) >= nv)
        throw InputError("", "decimate: triangle " + std::to_string(f) + " references vertex " + std::to_string(v) +
                                 " of " + std::to_string(nv));
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2])
      throw InputError("", "decimate: triangle " + std::to_string(f) + " repeats a vertex");
  }
  DecimateResult result{long(nf), long(nf)};
  if (params.max_error == 0 || nf == 0) return result;

  using detail::OmMesh;
  OmMesh om;
  om.reserve(nv, 3 * nf / 2, nf);
  std::vector<OmMesh::VertexHandle> handles(nv);
  for (std::size_t v = 0; v < nv; ++v) {
    const Vec3f& p = mesh.vertices[v];
    handles[v] = om.add_vertex(detail::OmPoint(p.x(), p.y(), p.z()));
  }
  for (std::size_t f = 0; f < nf; ++f) {
    const auto& t = mesh.triangles[f];
    if (!om.add_face(handles[std::size_t(t[0])], handles[std::size_t(t[1])], handles[std::size_t(t[2])]).is_valid())
      throw InputError("", "decimate: triangle " + std::to_string(f) +
                               " shares an edge with two triangles, or runs along it the same way as its neighbour");
  }
  om.request_face_normals();
  om.update_face_normals();

  {
    OpenMesh::Decimater::DecimaterT<OmMesh> decimater(om);
    OpenMesh::Decimater::ModNormalFlippingT<OmMesh>::Handle flipping;  // binary: runs first
    detail::ModBoundedQuadricT<OmMesh>::Handle priority;
    decimater.add(flipping);
    decimater.module(flipping).set_max_normal_deviation(params.max_normal_deviation_deg);
    decimater.add(priority);
    decimater.module(priority).set_tolerance(params.max_error);
    if (!decimater.initialize()) throw Error("decimate: OpenMesh decimater failed to initialise");
    decimater.decimate();
  }
  om.garbage_collection();

  TriMesh out;
  out.vertices.reserve(om.n_vertices());
  for (auto v : om.vertices()) {
    const auto& p = om.point(v);
    out.vertices.emplace_back(float(p[0]), float(p[1]), float(p[2]));
  }
  out.triangles.reserve(om.n_faces());
  for (auto f : om.faces()) {
    std::array<std::int32_t, 3> t{};
    int k = 0;
    for (auto v : om.fv_range(f)) t[std::size_t(k++)] = std::int32_t(v.idx());
    out.triangles.push_back(t);
  }
  result.triangles_after = long(out.triangles.size());
  mesh = std::move(out);
  return result;
}

}  // namespace isoloft
