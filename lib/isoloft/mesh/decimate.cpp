#include "isoloft/mesh/decimate.h"

#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
// QuadricT.hh needs vector_traits from the mesh headers: keep it after them.
#include <OpenMesh/Core/Geometry/QuadricT.hh>
#include <OpenMesh/Tools/Decimater/BaseDecimaterT.hh>
#include <OpenMesh/Tools/Decimater/ModBaseT.hh>
#include <OpenMesh/Tools/Decimater/ModNormalFlippingT.hh>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <queue>
#include <string>
#include <tuple>
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

// A triangle prepared for many squared-distance queries; exact also for
// zero-area triangles (then the distance to the nearest side).
struct PreparedTriangle {
  Vec3d a, b, c, ab, bc, ca, n, in_ab, in_bc, in_ca;
  double inv_n2, inv_ab2, inv_bc2, inv_ca2;

  PreparedTriangle(const Vec3d& a_, const Vec3d& b_, const Vec3d& c_)
      : a(a_), b(b_), c(c_), ab(b - a), bc(c - b), ca(a - c), n(ab.cross(c - a)) {
    const double n2 = n.squaredNorm();
    inv_n2 = n2 > 0 ? 1.0 / n2 : 0.0;
    in_ab = n.cross(ab), in_bc = n.cross(bc), in_ca = n.cross(ca);  // point into the triangle
    auto inv = [](const Vec3d& e) { return e.squaredNorm() > 0 ? 1.0 / e.squaredNorm() : 0.0; };
    inv_ab2 = inv(ab), inv_bc2 = inv(bc), inv_ca2 = inv(ca);
  }

  [[nodiscard]] double distance_sq(const Vec3d& p) const {
    const Vec3d pa = p - a, pb = p - b, pc = p - c;
    if (inv_n2 > 0 && pa.dot(in_ab) >= 0 && pb.dot(in_bc) >= 0 && pc.dot(in_ca) >= 0) {
      const double h = pa.dot(n);  // projection inside: distance to the plane
      return h * h * inv_n2;
    }
    auto segment = [](const Vec3d& q, const Vec3d& e, double inv_len2) {  // q relative to the segment start
      const double t = std::clamp(q.dot(e) * inv_len2, 0.0, 1.0);
      return (q - t * e).squaredNorm();
    };
    return std::min({segment(pa, ab, inv_ab2), segment(pb, bc, inv_bc2), segment(pc, ca, inv_ca2)});
  }
};

// A part of an original triangle: the whole triangle, or a piece of its
// midpoint subdivision. Bit k of `original` marks corner k as an original
// vertex, held to max_error itself (the other corners get the slack).
// `path` holds the child indices (0-3, see split()) from the triangle down,
// two bits per level, last level lowest.
struct Piece {
  std::array<Vec3d, 3> p;
  std::uint32_t triangle = 0;
  std::uint8_t original = 0;
  std::uint8_t depth = 0;
  std::uint64_t path = 0;
};
constexpr int kMaxPieceDepth = 31;  // 2 bits per level in Piece::path

// The four pieces of q's midpoint subdivision (child k keeps corner k).
std::array<Piece, 4> split(const Piece& q) {
  const Vec3d m01 = 0.5 * (q.p[0] + q.p[1]), m12 = 0.5 * (q.p[1] + q.p[2]), m20 = 0.5 * (q.p[2] + q.p[0]);
  const std::uint8_t d = q.depth + 1;
  const std::uint64_t path = q.path << 2;
  return {Piece{{q.p[0], m01, m20}, q.triangle, std::uint8_t(q.original & 1u), d, path},
          Piece{{m01, q.p[1], m12}, q.triangle, std::uint8_t(q.original & 2u), d, path | 1u},
          Piece{{m20, m12, q.p[2]}, q.triangle, std::uint8_t(q.original & 4u), d, path | 2u},
          Piece{{m01, m12, m20}, q.triangle, 0u, d, path | 3u}};
}

// Replaces every complete set of four sibling pieces by their parent, bottom
// up, so that splits made for creases that are gone are undone (the parent's
// corners are corners of its children 0-2, bit for bit).
void coarsen(std::vector<Piece>& pieces, std::vector<Piece>& scratch) {
  auto order = [](const Piece& a, const Piece& b) {
    return std::tie(a.triangle, a.depth, a.path) < std::tie(b.triangle, b.depth, b.path);
  };
  for (bool merged = true; merged;) {
    merged = false;
    std::sort(pieces.begin(), pieces.end(), order);
    scratch.clear();
    for (std::size_t i = 0; i < pieces.size();) {
      const Piece& a = pieces[i];
      auto sibling = [&](std::size_t k) {
        const Piece& b = pieces[i + k];
        return b.triangle == a.triangle && b.depth == a.depth && b.path == (a.path | k);
      };
      if (a.depth > 0 && (a.path & 3u) == 0 && i + 3 < pieces.size() && sibling(1) && sibling(2) && sibling(3)) {
        scratch.push_back(Piece{{a.p[0], pieces[i + 1].p[1], pieces[i + 2].p[2]},
                                a.triangle,
                                std::uint8_t(a.original | pieces[i + 1].original | pieces[i + 2].original),
                                std::uint8_t(a.depth - 1),
                                a.path >> 2});
        i += 4;
        merged = true;
      } else {
        scratch.push_back(a);
        ++i;
      }
    }
    pieces.swap(scratch);
  }
}

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
      m.property(pieces_, f).assign(1, Piece{{to_vec(m.point(a)), to_vec(m.point(b)), to_vec(m.point(c))}, std::uint32_t(f.idx()), 7u, 0u, 0u});
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
    auto ignore = [](std::size_t, const Piece&) {};
    for (auto [f, own] : around_)
      for (const Piece& piece : Base::mesh().property(pieces_, f))
        if (!(own >= 0 && covered_by(tris_[std::size_t(own)], piece)) && !cover(piece, own, false, ignore)) return false;
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
    auto store = [&](std::size_t k, const Piece& q) { m.property(pieces_, faces_[k]).push_back(q); };
    coarsen(moved_, scratch_);
    for (const Piece& piece : moved_) cover(piece, -1, true, store);
  }

 private:
  // Whether each corner of q is within its bound of t (the fast path of cover()).
  [[nodiscard]] bool covered_by(const PreparedTriangle& t, const Piece& q) const {
    for (std::size_t k = 0; k < 3; ++k)
      if (t.distance_sq(q.p[k]) > ((q.original >> k & 1u) ? vertex_tol2_ : surface_tol2_)) return false;
    return true;
  }

  // Covers `piece` by faces of tris_, splitting it where no single face
  // covers it, and calls place(k, part) for every covered part (k: the first
  // covering face, `hint` tried first; with `best`, the one with the smallest
  // largest corner distance). A face covers a part if each corner is within
  // its bound of it (original vertices: max_error; other corners: max_error +
  // kDecimateSurfaceSlack); the distance to a triangle is convex, so then
  // every point of the part is. Returns false (the collapse is illegal) if a
  // part no face covers has a corner farther than its bound from every face,
  // or is small (longest side <= kDecimateSurfaceSlack, at most one original
  // corner v): were every point within max_error, the face nearest to v would
  // cover it (its corners are within max_error + that side of the face).
  // Whether a part is split or rejected does not depend on hint and best, so
  // postprocess_collapse() makes the same splits as within_tolerance(); there
  // a rejected part (unreachable) goes to the nearest face, not lost.
  template <class Place>
  bool cover(const Piece& piece, int hint, bool best, Place&& place) {
    constexpr double kInf = std::numeric_limits<double>::infinity();
    const double smallest2 = kDecimateSurfaceSlack * kDecimateSurfaceSlack;
    const std::size_t n = tris_.size();
    stack_.assign(1, piece);
    while (!stack_.empty()) {
      const Piece q = stack_.back();
      stack_.pop_back();
      std::array<double, 3> bound{};
      for (std::size_t k = 0; k < 3; ++k) bound[k] = (q.original >> k & 1u) ? vertex_tol2_ : surface_tol2_;
      unsigned reached = 0;      // bit k: corner k is within its bound of some face
      tested_.assign(n, 0u);     // bit k of tested_[j]: corner k measured against face j
      auto covers = [&](std::size_t j, double& worst) {
        worst = 0;
        for (std::size_t k = 0; k < 3; ++k) {
          const double d = tris_[j].distance_sq(q.p[k]);
          tested_[j] |= 1u << k;
          if (d > bound[k]) return false;
          reached |= 1u << k;
          worst = std::max(worst, d);
        }
        return true;
      };
      std::size_t chosen = n;
      double chosen_d = kInf, d = 0;
      if (hint >= 0 && !best && covers(std::size_t(hint), d)) chosen = std::size_t(hint);
      for (std::size_t j = 0; j < n && (best || chosen == n); ++j)
        if (tested_[j] == 0 && covers(j, d) && d < chosen_d) chosen_d = d, chosen = j;
      if (chosen < n) {
        place(chosen, q);
        continue;
      }
      bool rejected = false;
      for (std::size_t k = 0; k < 3 && !rejected; ++k) {
        if (reached >> k & 1u) continue;
        rejected = true;
        for (std::size_t j = 0; j < n && rejected; ++j)
          if (!(tested_[j] >> k & 1u) && tris_[j].distance_sq(q.p[k]) <= bound[k]) rejected = false;
      }
      const double side2 =
          std::max({(q.p[1] - q.p[0]).squaredNorm(), (q.p[2] - q.p[1]).squaredNorm(), (q.p[0] - q.p[2]).squaredNorm()});
      if (rejected || (side2 <= smallest2 && std::popcount(unsigned(q.original)) <= 1) || q.depth == kMaxPieceDepth) {
        if (!best) return false;
        std::size_t nearest = 0;  // unreachable in postprocess: keep the part
        double nearest_d = kInf;
        for (std::size_t j = 0; j < n; ++j) {
          double dj = 0;
          for (const Vec3d& p : q.p) dj = std::max(dj, tris_[j].distance_sq(p));
          if (dj < nearest_d) nearest_d = dj, nearest = j;
        }
        place(nearest, q);
        continue;
      }
      for (const Piece& child : split(q)) stack_.push_back(child);
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
        std::array<Vec3d, 3> t;
        int k = 0;
        for (auto v : m.fv_range(f)) t[std::size_t(k++)] = to_vec(v == ci.v0 ? ci.p1 : m.point(v));
        tris_.emplace_back(t[0], t[1], t[2]);
      }
      around_.emplace_back(f, own);
    }
  }

  double vertex_tol2_ = 0.0, surface_tol2_ = 0.0;
  OpenMesh::FPropHandleT<Pieces> pieces_;
  OpenMesh::VPropHandleT<Quadric> quadrics_;
  std::vector<FaceHandle> faces_;
  std::vector<PreparedTriangle> tris_;
  std::vector<std::pair<FaceHandle, int>> around_;
  Pieces moved_, stack_, scratch_;
  std::vector<unsigned> tested_;
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
