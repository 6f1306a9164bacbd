#include "isoloft/mesh/decimate.h"

#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
// QuadricT.hh needs vector_traits from the mesh headers: keep it after them.
#include <OpenMesh/Core/Geometry/QuadricT.hh>
#include <OpenMesh/Tools/Decimater/DecimaterT.hh>
#include <OpenMesh/Tools/Decimater/ModBaseT.hh>
#include <OpenMesh/Tools/Decimater/ModNormalFlippingT.hh>
#include <algorithm>
#include <array>
#include <bit>
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

// A part of an original triangle: the whole triangle, or a piece of its
// midpoint subdivision. Bit k of `original` marks corner k as an original
// vertex, held to max_error itself (the other corners get the slack).
struct Piece {
  std::array<OmPoint, 3> p;
  unsigned original = 0;
};

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
// Decimater re-queues), zero-area faces get their true distance, and the test
// runs lazily: DecimaterT::heap_vertex() evaluates all halfedges out of one
// vertex in a row and keeps the smallest priority, so a candidate whose
// quadric error is not below the best legal one so far for that vertex cannot
// be chosen and needs no test.
template <class MeshT>
class ModBoundedQuadricT : public OpenMesh::Decimater::ModBaseT<MeshT> {
 public:
  DECIMATING_MODULE(ModBoundedQuadricT, MeshT, BoundedQuadric);
  using Pieces = std::vector<Piece>;
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
  void set_tolerance(double tolerance) {
    vertex_tol2_ = tolerance * tolerance;
    surface_tol2_ = (tolerance + kDecimateSurfaceSlack) * (tolerance + kDecimateSurfaceSlack);
  }

  void initialize() override {
    MeshT& m = Base::mesh();
    for (auto v : m.vertices()) m.property(quadrics_, v).clear();
    for (auto f : m.faces()) {
      auto fv = m.cfv_iter(f);
      const VertexHandle a = *fv, b = *++fv, c = *++fv;
      m.property(pieces_, f).assign(1, Piece{{m.point(a), m.point(b), m.point(c)}, 7u});
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

  // Takes the pieces out of the faces around v0; collapse_priority() has just
  // accepted this collapse, so faces_ and tris_ describe it.
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
    sequence_v0_.reset();  // a new heap_vertex() sequence starts
    if (faces_.empty()) return;  // unreachable: within_tolerance() rejects it
    auto store = [&](std::size_t k, const Piece& q) { m.property(pieces_, faces_[k]).push_back(q); };
    for (const Piece& piece : moved_) cover(piece, -1, true, store);
  }

 private:
  // Every piece stored around v0 must be covered by the faces around v0 but
  // fl, fr after v0 moves to p1; each is first tested against the face that
  // holds it (usually enough).
  bool within_tolerance(const CollapseInfo& ci) {
    prepare(ci);
    auto ignore = [](std::size_t, const Piece&) {};
    for (auto [f, own] : around_)
      for (const Piece& piece : Base::mesh().property(pieces_, f))
        if (!cover(piece, own, false, ignore)) return false;
    return true;
  }

  // Largest squared corner distance of q to t, or infinity if a corner is
  // beyond its bound (original vertices: max_error; other corners: max_error
  // + kDecimateSurfaceSlack). By convexity, a finite result means every point
  // of q is within that bound of t.
  [[nodiscard]] double cover_distance_sq(const PreparedTriangle& t, const Piece& q) const {
    double worst = 0;
    for (std::size_t k = 0; k < 3; ++k) {
      const double d = t.distance_sq(q.p[k]);
      if (d > ((q.original >> k & 1u) ? vertex_tol2_ : surface_tol2_)) return std::numeric_limits<double>::infinity();
      worst = std::max(worst, d);
    }
    return worst;
  }

  // Covers `piece` by faces of tris_, splitting it where no single face
  // covers it, and calls place(k, part) for every covered part (k: the first
  // covering face, `hint` tried first; with `best`, the one with the smallest
  // corner distance). Whether a part is split does not depend on hint/best.
  // Returns false (the collapse is illegal) if a part with longest side <=
  // kDecimateSurfaceSlack and at most one original corner v is covered by no
  // face: were every point within max_error, the face nearest to v would
  // cover it (its corners are within max_error + that side of the face).
  // In postprocess (unreachable, see there) such a part goes to the face of
  // smallest corner distance instead of being lost.
  template <class Place>
  bool cover(const Piece& piece, int hint, bool best, Place&& place) {
    constexpr double kInf = std::numeric_limits<double>::infinity();
    const double smallest2 = kDecimateSurfaceSlack * kDecimateSurfaceSlack;
    stack_.assign(1, piece);
    while (!stack_.empty()) {
      const Piece q = stack_.back();
      stack_.pop_back();
      std::size_t chosen = tris_.size();
      if (hint >= 0 && !best && cover_distance_sq(tris_[std::size_t(hint)], q) < kInf) {
        chosen = std::size_t(hint);
      } else {
        double chosen_d = kInf;
        for (std::size_t k = 0; k < tris_.size(); ++k) {
          if (int(k) == hint && !best) continue;  // just tested
          const double d = cover_distance_sq(tris_[k], q);
          if (d < chosen_d) {
            chosen_d = d, chosen = k;
            if (!best) break;
          }
        }
      }
      if (chosen < tris_.size()) {
        place(chosen, q);
        continue;
      }
      const OmPoint m01 = 0.5 * (q.p[0] + q.p[1]), m12 = 0.5 * (q.p[1] + q.p[2]), m20 = 0.5 * (q.p[2] + q.p[0]);
      const double side2 = std::max({(q.p[1] - q.p[0]).sqrnorm(), (q.p[2] - q.p[1]).sqrnorm(), (q.p[0] - q.p[2]).sqrnorm()});
      if (side2 <= smallest2 && std::popcount(q.original) <= 1) {
        if (!best) return false;
        std::size_t nearest = 0;  // unreachable in postprocess: keep the part
        double nearest_d = kInf;
        for (std::size_t k = 0; k < tris_.size(); ++k) {
          double d = 0;
          for (const OmPoint& p : q.p) d = std::max(d, tris_[k].distance_sq(p));
          if (d < nearest_d) nearest_d = d, nearest = k;
        }
        place(nearest, q);
        continue;
      }
      stack_.push_back(Piece{{q.p[0], m01, m20}, q.original & 1u});
      stack_.push_back(Piece{{m01, q.p[1], m12}, q.original & 2u});
      stack_.push_back(Piece{{m20, m12, q.p[2]}, q.original & 4u});
      stack_.push_back(Piece{{m01, m12, m20}, 0u});
    }
    return true;
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

  double vertex_tol2_ = 0.0, surface_tol2_ = 0.0;
  OpenMesh::FPropHandleT<Pieces> pieces_;
  OpenMesh::VPropHandleT<Quadric> quadrics_;
  VertexHandle sequence_v0_;
  double sequence_best_ = 0.0;
  std::vector<FaceHandle> faces_;
  std::vector<PreparedTriangle> tris_;
  std::vector<std::pair<FaceHandle, int>> around_;
  Pieces moved_, stack_;
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
