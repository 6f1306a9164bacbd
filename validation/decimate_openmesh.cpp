// The reference decimator (decimate.h, detail::decimate_openmesh): the same
// bounded quadric decimation on OpenMesh's decimation framework, strictly
// greedy (one heap of collapses). 3.3-7x slower than decimate.cpp (measured:
// 38k triangles 888 vs 272 ms; 0.58 M triangles 27.5 vs 3.9 s, 2 threads);
// kept as its test oracle and for comparison (experiments/bench_pipeline).
#include "validation/decimate_openmesh.h"

#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
// QuadricT.hh needs vector_traits from the mesh headers: keep it after them.
#include <OpenMesh/Core/Geometry/QuadricT.hh>
#include <OpenMesh/Tools/Decimater/BaseDecimaterT.hh>
#include <OpenMesh/Tools/Decimater/ModBaseT.hh>
#include <OpenMesh/Tools/Decimater/ModNormalFlippingT.hh>
#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <queue>
#include <string>
#include <utility>
#include <vector>

#include "isoloft/core/error.h"
#include "isoloft/mesh/decimate_bound.h"

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
// calls ~60% of the decimation time. BaseDecimaterT::is_collapse_legal calls
// them through the mesh type, so these hide the library versions.
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

Vec3d to_vec(const OmPoint& p) { return {p[0], p[1], p[2]}; }

// The Decimater's one continuous module: Garland-Heckbert priority (the
// area-weighted plane quadrics of OpenMesh's ModQuadricT) with the error bound
// as a hard constraint. Bound scheme after OpenMesh's ModHausdorffT, but on
// the original surface instead of its vertices: every original triangle (or
// piece of one) is stored with one face of the current mesh that covers it,
// i.e. every point of it is within the bound of that face, and it is
// re-certified whenever that face changes. The distance to a triangle is
// convex, so a piece is covered by a face iff its three corners are: an exact
// test. A piece that no single face covers (it spans a crease of the current
// mesh) is split into four at its edge midpoints. Differences, see decimate.h:
// pieces go only to the faces that were around v0 (whose vertices the
// decimation loop re-queues), and zero-area faces get their true distance.
// The bound is not part of collapse_priority() (the quadric error): the loop,
// LazyBoundDecimater, calls within_tolerance() only for the collapses it is
// about to make.
template <class MeshT>
class ModBoundedQuadricT : public OpenMesh::Decimater::ModBaseT<MeshT> {
 public:
  DECIMATING_MODULE(ModBoundedQuadricT, MeshT, BoundedQuadric);
  using Pieces = std::vector<TrianglePiece>;
  using FaceHandle = typename MeshT::FaceHandle;
  using VertexHandle = typename MeshT::VertexHandle;
  using Quadric = OpenMesh::Geometry::QuadricT<double>;

  explicit ModBoundedQuadricT(MeshT& mesh) : Base(mesh, false) {
    mesh.add_property(pieces_);
    mesh.add_property(quadrics_);
  }
  ~ModBoundedQuadricT() override {
    Base::mesh().remove_property(pieces_);
    Base::mesh().remove_property(quadrics_);
  }
  void set_tolerance(double tolerance) { cover_.emplace(tolerance); }

  void initialize() override {
    MeshT& m = Base::mesh();
    for (auto v : m.vertices()) m.property(quadrics_, v).clear();
    for (auto f : m.faces()) {
      auto fv = m.cfv_iter(f);
      const VertexHandle a = *fv, b = *++fv, c = *++fv;
      m.property(pieces_, f).assign(1, TrianglePiece{{to_vec(m.point(a)), to_vec(m.point(b)), to_vec(m.point(c))}, std::uint32_t(f.idx()), 7u, 0u, 0u});
      OmPoint n = (m.point(b) - m.point(a)) % (m.point(c) - m.point(a));
      const double twice_area = n.norm();
      if (twice_area <= 0) continue;  // no plane; contributes nothing
      n /= twice_area;
      Quadric q(n[0], n[1], n[2], -(m.point(a) | n));
      q *= 0.5 * twice_area;
      for (VertexHandle v : {a, b, c}) m.property(quadrics_, v) += q;
    }
  }

  float collapse_priority(const CollapseInfo& ci) override {
    MeshT& m = Base::mesh();
    Quadric q = m.property(quadrics_, ci.v0);
    q += m.property(quadrics_, ci.v1);
    return float(std::max(0.0, q(ci.p1)));  // >= 0 up to rounding
  }

  // Every piece stored around v0 must be covered by the faces around v0 but
  // fl, fr after v0 moves to p1; each is first tested against the face that
  // holds it (usually enough).
  bool within_tolerance(const CollapseInfo& ci) {
    prepare(ci);
    auto ignore = [](std::size_t, const TrianglePiece&) {};
    for (auto [f, own] : around_)
      for (const TrianglePiece& piece : Base::mesh().property(pieces_, f))
        if (!(own >= 0 && cover_->covered_by(tris_[std::size_t(own)], piece)) && !cover_->cover(piece, tris_, own, false, ignore))
          return false;
    return true;
  }

  // Takes the pieces out of the faces around v0; within_tolerance() has
  // accepted this collapse in the current mesh.
  void preprocess_collapse(const CollapseInfo& ci) override {
    prepare(ci);
    moved_.clear();
    for (auto [f, own] : around_) {
      Pieces& stored = Base::mesh().property(pieces_, f);
      moved_.insert(moved_.end(), stored.begin(), stored.end());
      stored.clear();
    }
  }

  // The faces that were around v0 (but fl, fr) now have v1 instead; each
  // piece goes to the covering face with the most margin, split as in
  // within_tolerance() (the same decisions, as they do not depend on order).
  void postprocess_collapse(const CollapseInfo& ci) override {
    MeshT& m = Base::mesh();
    m.property(quadrics_, ci.v1) += m.property(quadrics_, ci.v0);
    if (faces_.empty()) return;  // unreachable: within_tolerance() rejects it
    auto store = [&](std::size_t k, const TrianglePiece& q) { m.property(pieces_, faces_[k]).push_back(q); };
    coarsen(moved_);
    for (const TrianglePiece& piece : moved_) cover_->cover(piece, tris_, -1, true, store);
  }

 private:
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
        std::array<Vec3d, 3> t;
        int k = 0;
        for (auto v : m.fv_range(f)) t[std::size_t(k++)] = to_vec(v == ci.v0 ? ci.p1 : m.point(v));
        tris_.emplace_back(t[0], t[1], t[2]);
      }
      around_.emplace_back(f, own);
    }
  }

  std::optional<PieceCover> cover_;
  OpenMesh::FPropHandleT<Pieces> pieces_;
  OpenMesh::VPropHandleT<Quadric> quadrics_;
  std::vector<FaceHandle> faces_;
  std::vector<PreparedTriangle> tris_;
  std::vector<std::pair<FaceHandle, int>> around_;
  Pieces moved_;
};

using BoundedQuadric = ModBoundedQuadricT<OmMesh>;

// OpenMesh's DecimaterT loop -- a heap of vertices, each keyed by its
// cheapest legal halfedge collapse -- with the error bound tested lazily. A
// vertex's key is the quadric error of its cheapest collapse that passes the
// cheap tests (topology, normal deviation); the bound is tested only when the
// vertex comes to the front. If the bound fails there, the vertex's
// collapses are tested in order of error and it goes back on the heap keyed
// by the first that passes, marked as tested. Keys only grow when a test
// fails, so the collapses are those of testing every candidate up front (as
// DecimaterT with the bound inside collapse_priority() would), with ~1/8 of
// the bound tests.
class LazyBoundDecimater : public OpenMesh::Decimater::BaseDecimaterT<OmMesh> {
 public:
  explicit LazyBoundDecimater(OmMesh& mesh) : BaseDecimaterT(mesh) {}

  /// Collapses until no collapse is legal; returns how many were made.
  std::size_t decimate(BoundedQuadric& bound) {
    OmMesh& m = mesh();
    const std::size_t nv = m.n_vertices();
    stamp_.assign(nv, 0u);
    target_.assign(nv, OmMesh::HalfedgeHandle());
    bound_tested_.assign(nv, 0);
    heap_ = {};
    for (auto v : m.vertices())
      if (!m.status(v).deleted()) enqueue(v, nullptr);
    std::size_t collapses = 0;
    std::vector<OmMesh::VertexHandle> support;
    while (!heap_.empty()) {
      const Entry e = heap_.top();
      heap_.pop();
      const auto v = OmMesh::VertexHandle(e.vertex);
      const auto i = std::size_t(e.vertex);
      if (e.stamp != stamp_[i] || m.status(v).deleted()) continue;  // stale entry
      ++stamp_[i];  // off the heap
      CollapseInfo ci(m, target_[i]);
      if (!is_collapse_legal(ci)) continue;  // as DecimaterT: topology checked again
      if (!bound_tested_[i] && !bound.within_tolerance(ci)) {
        enqueue(v, &bound, ci.v0v1);
        continue;
      }
      support.clear();
      for (auto w : m.vv_range(ci.v0)) support.push_back(w);
      preprocess_collapse(ci);
      m.collapse(ci.v0v1);
      ++collapses;
      for (auto f : m.vf_range(ci.v1)) m.set_normal(f, m.calc_face_normal(f));  // ModNormalFlippingT compares to these
      postprocess_collapse(ci);
      for (auto w : support) enqueue(w, nullptr);
    }
    return collapses;
  }

 private:
  struct Entry {
    float priority;
    int vertex;
    unsigned stamp;  // valid while equal to stamp_[vertex]
    bool operator<(const Entry& o) const {  // std::priority_queue pops the largest: invert
      return priority > o.priority || (priority == o.priority && vertex > o.vertex);
    }
  };

  // Keys v by its cheapest collapse that passes is_collapse_legal() and the
  // modules' collapse_priority(); with `bound`, by its cheapest that also
  // passes the bound (candidates tested in order of priority; `failed` has
  // just failed it). Removes v from the heap if there is none.
  void enqueue(OmMesh::VertexHandle v, BoundedQuadric* bound, OmMesh::HalfedgeHandle failed = OmMesh::HalfedgeHandle()) {
    OmMesh& m = mesh();
    const auto i = std::size_t(v.idx());
    ++stamp_[i];
    candidates_.clear();
    for (auto h : m.voh_range(v)) {
      CollapseInfo ci(m, h);
      if (!is_collapse_legal(ci)) continue;
      const float priority = collapse_priority(ci);
      if (priority >= 0) candidates_.emplace_back(priority, h);
    }
    auto by_priority = [](const auto& a, const auto& b) { return a.first < b.first; };
    std::stable_sort(candidates_.begin(), candidates_.end(), by_priority);
    for (const auto& [priority, h] : candidates_) {
      if (bound && (h == failed || !bound->within_tolerance(CollapseInfo(m, h)))) continue;
      target_[i] = h;
      bound_tested_[i] = bound != nullptr;
      heap_.push(Entry{priority, v.idx(), stamp_[i]});
      return;
    }
  }

  std::priority_queue<Entry> heap_;
  std::vector<unsigned> stamp_;
  std::vector<OmMesh::HalfedgeHandle> target_;
  std::vector<char> bound_tested_;  // the key's collapse passed within_tolerance()
  std::vector<std::pair<float, OmMesh::HalfedgeHandle>> candidates_;
};

}  // namespace
}  // namespace detail

DecimateResult detail::decimate_openmesh(TriMesh& mesh, const DecimateParams& params) {
  detail::validate_decimate_input(mesh, params);
  const std::size_t nv = mesh.vertices.size(), nf = mesh.triangles.size();
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
    detail::LazyBoundDecimater decimater(om);
    OpenMesh::Decimater::ModNormalFlippingT<OmMesh>::Handle flipping;  // binary: runs first
    detail::BoundedQuadric::Handle priority;
    decimater.add(flipping);
    decimater.module(flipping).set_max_normal_deviation(params.max_normal_deviation_deg);
    decimater.add(priority);
    decimater.module(priority).set_tolerance(params.max_error);
    if (!decimater.initialize()) throw Error("decimate: OpenMesh decimater failed to initialise");
    decimater.decimate(decimater.module(priority));
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
