#include "isoloft/mesh/decimate.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <numeric>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/LU>

#include "isoloft/core/error.h"
#include "isoloft/mesh/decimate_bound.h"

namespace isoloft {

namespace detail {

void validate_decimate_input(const TriMesh& mesh, const DecimateParams& params) {
  params_table<DecimateParams>().validate(params);
  const std::size_t nv = mesh.vertices.size();
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    const auto& t = mesh.triangles[f];
    for (std::int32_t v : t)
      if (v < 0 || std::size_t(v) >= nv)
        throw InputError("", "decimate: triangle " + std::to_string(f) + " references vertex " + std::to_string(v) +
                                 " of " + std::to_string(nv));
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2])
      throw InputError("", "decimate: triangle " + std::to_string(f) + " repeats a vertex");
  }
}

namespace {

// Vertex states.
constexpr std::uint8_t kDead = 1;     // collapsed away
constexpr std::uint8_t kFixed = 2;    // boundary or non-manifold vertex: never moved, never a target
constexpr std::uint8_t kDirty = 4;    // its neighbourhood changed: its edges are candidates next round
constexpr std::uint8_t kTouched = 8;  // target of a collapse this round: its costs are stale until the next
constexpr std::uint8_t kBorder = 16;  // has a neighbour in another slab: fixed while the slabs run in parallel

// Large meshes are first decimated in z slabs concurrently, each slab's
// vertices next to another slab held fixed (so no two slabs touch one face,
// vertex or piece), then the seams serially. The slab count depends on the
// mesh only, never on the thread count: the output is the same for any
// --threads. One slab per this many triangles, at most kMaxSlabs.
constexpr std::size_t kTrianglesPerSlab = 100000;
constexpr std::size_t kMaxSlabs = 8;

// Passes over the slivers (min_angle_deg): a pass that changes nothing ends
// them; 48 only bounds the time (at 10 deg the frog at 0.5 px ends after 24
// passes, the jawbone stack at 1 px after 38).
constexpr int kSliverPasses = 48;
// Where a moved vertex is tried (min_angle_deg). A cap's apex: these
// fractions of the way to its foot on the long edge.
constexpr double kCapSteps[] = {1.0, 0.5, 0.25};
// A relaxed corner: these fractions of the way to its ring's centroid, and of
// kRelaxReach times its nearest neighbour's distance in kRelaxDirections
// tangent directions (an edge collapsed inside: of kRelaxReach times its
// length around its midpoint). Frog 0.5 px at 10 deg, faces below it: 8
// directions, 4 steps 4; 16 directions, 5 steps 2 (jawbone 20 -> 10).
constexpr double kRelaxSteps[] = {1.0, 0.5, 0.25, 0.125, 0.0625};
constexpr int kRelaxDirections = 16;
constexpr double kRelaxReach = 0.5;

// Least interior angle of the triangle (a, b, c), radians (the one facing
// its shortest side); 0 if degenerate.
double least_angle(const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  const std::array<const Vec3d*, 3> corner{&a, &b, &c};
  const double ab = (b - a).squaredNorm(), bc = (c - b).squaredNorm(), ca = (a - c).squaredNorm();
  const std::size_t k = ab <= bc && ab <= ca ? 2 : bc <= ca ? 0 : 1;  // the corner facing the shortest side
  const Vec3d u = *corner[(k + 1) % 3] - *corner[k], v = *corner[(k + 2) % 3] - *corner[k];
  return std::atan2(u.cross(v).norm(), u.dot(v));
}

// Candidates are ordered by the top 16 bits of their float cost (sign 0,
// 8 exponent, 7 mantissa bits): relative steps of < 1 %, a counting sort.
constexpr int kCostKeyShift = 16;

struct Candidate {
  float cost;
  std::int32_t from, to;  // collapse `from` into `to`; the reverse is tried if this one is illegal
};

// A face's new corners in a vertex move ({-1, -1, -1}: removed) and the
// normal its new shape may turn from by at most the limit.
struct Change {
  std::int32_t face;
  std::array<std::int32_t, 3> now;
  Vec3d normal;
};

// Working memory of one decimation loop (one per slab running concurrently).
struct Scratch {
  explicit Scratch(double tolerance) : cover(tolerance) {}
  PieceCover cover;
  unsigned stamp = 0;  // marks in mark_ equal to it are this collapse's
  std::vector<Candidate> candidates, sorted;
  std::vector<std::uint32_t> count;
  std::vector<PreparedTriangle> tris;
  std::vector<std::int32_t> kept, own;
  std::vector<std::pair<std::int32_t, PieceKey>> placed;          // (index in kept, part)
  std::vector<std::pair<std::int32_t, std::uint32_t>> leaving;    // (index in kept, index in its pieces)
  std::vector<Change> changes;                                    // of a vertex move (reshape)
};

class FastDecimator {
 public:
  FastDecimator(const TriMesh& mesh, const DecimateParams& params)
      : tolerance_(params.max_error),
        cos_max_(std::cos(params.max_normal_deviation_deg * std::numbers::pi / 180.0)),
        min_angle_(params.min_angle_deg * std::numbers::pi / 180.0) {
    const std::size_t nv = mesh.vertices.size(), nf = mesh.triangles.size();
    pos_.reserve(nv);
    for (const Vec3f& p : mesh.vertices) pos_.emplace_back(p.cast<double>());
    tri_ = mesh.triangles;
    original_ = mesh.triangles;
    faces_of_.resize(nv);
    {
      std::vector<std::uint32_t> valence(nv, 0);
      for (const auto& t : tri_)
        for (std::int32_t v : t) ++valence[std::size_t(v)];
      for (std::size_t v = 0; v < nv; ++v) faces_of_[v].reserve(valence[v]);
    }
    for (std::size_t f = 0; f < nf; ++f)
      for (std::int32_t v : tri_[f]) faces_of_[std::size_t(v)].push_back(std::int32_t(f));
    state_.assign(nv, 0);
    mark_.assign(nv, 0);
    for (std::size_t v = 0; v < nv; ++v) classify(std::int32_t(v));

    // Each vertex sums the quadrics of its faces in face order (the same
    // bits for any thread count).
    quad_.assign(nv, Quadric{});
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv), [&](const tbb::blocked_range<std::size_t>& r) {
      for (std::size_t v = r.begin(); v < r.end(); ++v)
        for (std::int32_t f : faces_of_[v]) {
          const auto& t = tri_[std::size_t(f)];
          const Vec3d &a = pos_[std::size_t(t[0])], &b = pos_[std::size_t(t[1])], &c = pos_[std::size_t(t[2])];
          Vec3d n = (b - a).cross(c - a);
          const double twice_area = n.norm();
          if (twice_area <= 0) continue;  // no plane; contributes nothing
          n /= twice_area;
          quad_[v] += Quadric::plane(n, -a.dot(n), 0.5 * twice_area);
        }
    });
    pieces_.resize(nf);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nf), [&](const tbb::blocked_range<std::size_t>& r) {
      for (std::size_t f = r.begin(); f < r.end(); ++f) pieces_[f].assign(1, PieceKey{0u, std::uint32_t(f), 7u, 0u});
    });
  }

  void run(std::size_t slabs) {
    for (auto& s : state_)
      if (!(s & kFixed)) s |= kDirty;
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const Vec3d& p : pos_) lo = std::min(lo, p.z()), hi = std::max(hi, p.z());
    if (slabs > 1 && hi > lo) in_slabs(slabs, lo, hi);  // not flat in z (nor empty): there is something to cut
    std::vector<std::int32_t> all(state_.size());
    std::iota(all.begin(), all.end(), 0);
    Scratch scratch(tolerance_);
    rounds(scratch, all);
    // Slivers the collapses left (Marching Cubes' are mostly gone by now):
    // flip, collapse or move them away, then collapse again around the
    // changes, from here on making no new sliver.
    guard_angles_ = min_angle_ > 0;
    if (guard_angles_) {
      input_ = pos_;  // vertices may move from here on
      version_.assign(pos_.size(), 0);
      stuck_.assign(tri_.size(), 0);
    }
    for (int pass = 0; pass < kSliverPasses && guard_angles_; ++pass) {
      const long before = flips_ + sliver_collapses_ + sliver_moves_;
      for (std::size_t f = 0; f < tri_.size(); ++f)
        if (tri_[f][0] >= 0) lift_sliver(scratch, std::int32_t(f));
      for (auto& st : state_) st &= std::uint8_t(~kTouched);
      if (flips_ + sliver_collapses_ + sliver_moves_ == before) break;
      rounds(scratch, all);
    }
  }

  [[nodiscard]] long flips() const { return flips_; }
  [[nodiscard]] long sliver_collapses() const { return sliver_collapses_; }
  [[nodiscard]] long sliver_moves() const { return sliver_moves_; }

  [[nodiscard]] TriMesh result() const {
    TriMesh out;
    std::vector<std::int32_t> index(pos_.size(), -1);
    for (std::size_t v = 0; v < pos_.size(); ++v)
      if (!(state_[v] & kDead)) {
        index[v] = std::int32_t(out.vertices.size());
        out.vertices.push_back(pos_[v].cast<float>());  // an input or representable() float: exact
      }
    for (const auto& t : tri_)
      if (t[0] >= 0) out.triangles.push_back({index[std::size_t(t[0])], index[std::size_t(t[1])], index[std::size_t(t[2])]});
    return out;
  }

 private:
  // Rounds over `count` z slabs concurrently (slab k: vertices with z in the
  // k-th of `count` equal parts of [lo, hi]); the vertices of faces that span
  // two slabs are held, then set free for the seams.
  void in_slabs(std::size_t count, double lo, double hi) {
    std::vector<std::uint8_t> slab(pos_.size());
    for (std::size_t v = 0; v < pos_.size(); ++v)
      slab[v] = std::uint8_t(std::min(double(count) - 1, std::floor((pos_[v].z() - lo) / (hi - lo) * double(count))));
    for (const auto& t : tri_)
      if (slab[std::size_t(t[0])] != slab[std::size_t(t[1])] || slab[std::size_t(t[1])] != slab[std::size_t(t[2])])
        for (std::int32_t v : t) state_[std::size_t(v)] |= kBorder;
    std::vector<std::vector<std::int32_t>> members(count);
    for (std::size_t v = 0; v < pos_.size(); ++v) members[slab[v]].push_back(std::int32_t(v));
    tbb::parallel_for(std::size_t(0), count, [&](std::size_t k) {
      Scratch scratch(tolerance_);
      rounds(scratch, members[k]);
    });
    for (auto& s : state_)  // held vertices are candidates again
      if (s & kBorder) s = std::uint8_t((s & ~kBorder) | kDirty);
    std::fill(mark_.begin(), mark_.end(), 0u);  // the next Scratch counts its stamps from 0 again
  }

  // Rounds of collapses among `verts` until none is legal: each round lists
  // the edges of the vertices whose neighbourhood changed, orders them by
  // quadric error and makes every legal one.
  void rounds(Scratch& s, const std::vector<std::int32_t>& verts) {
    constexpr std::uint8_t kHeld = kFixed | kBorder;
    for (;;) {
      s.candidates.clear();
      for (std::int32_t v : verts) {
        if ((state_[std::size_t(v)] & (kDirty | kDead | kHeld)) != kDirty) continue;
        for (std::int32_t f : faces_of_[std::size_t(v)]) {
          const std::int32_t b = after(f, v);  // each neighbour once around a closed fan
          const std::uint8_t sb = state_[std::size_t(b)];
          if ((sb & kHeld) || ((sb & kDirty) && b < v)) continue;  // held, or listed from b
          Quadric q = quad_[std::size_t(v)];
          q += quad_[std::size_t(b)];
          const double into_b = q(pos_[std::size_t(b)]), into_v = q(pos_[std::size_t(v)]);
          s.candidates.push_back(into_b <= into_v ? Candidate{float(std::max(0.0, into_b)), v, b}
                                                  : Candidate{float(std::max(0.0, into_v)), b, v});
        }
      }
      for (std::int32_t v : verts) state_[std::size_t(v)] &= std::uint8_t(~kDirty);
      if (s.candidates.empty()) return;

      s.count.assign((1u << (31 - kCostKeyShift)) + 1, 0);
      auto key = [](float c) { return std::bit_cast<std::uint32_t>(c) >> kCostKeyShift; };
      for (const Candidate& c : s.candidates) ++s.count[key(c.cost) + 1];
      for (std::size_t k = 1; k < s.count.size(); ++k) s.count[k] += s.count[k - 1];
      s.sorted.resize(s.candidates.size());
      for (const Candidate& c : s.candidates) s.sorted[s.count[key(c.cost)]++] = c;

      for (const Candidate& c : s.sorted) {
        if ((state_[std::size_t(c.from)] | state_[std::size_t(c.to)]) & (kDead | kTouched)) continue;
        if (!collapse(s, c.from, c.to)) collapse(s, c.to, c.from);
      }
      for (std::int32_t v : verts) state_[std::size_t(v)] &= std::uint8_t(~kTouched);
    }
  }

  // The vertex after v in face f (counter-clockwise).
  [[nodiscard]] std::int32_t after(std::int32_t f, std::int32_t v) const {
    const auto& t = tri_[std::size_t(f)];
    return t[0] == v ? t[1] : t[1] == v ? t[2] : t[0];
  }

  // Throws for an edge used twice in one direction (decimate.h \throw); marks
  // v kFixed unless its faces form one closed fan (boundary, or several fans).
  void classify(std::int32_t v) {
    const auto& fs = faces_of_[std::size_t(v)];
    if (fs.empty()) return;
    for (std::size_t i = 0; i < fs.size(); ++i)
      for (std::size_t j = 0; j < i; ++j)
        if (after(fs[i], v) == after(fs[j], v))
          throw InputError("", "decimate: triangle " + std::to_string(std::max(fs[i], fs[j])) + " uses the edge " +
                                   std::to_string(v) + "->" + std::to_string(after(fs[i], v)) +
                                   " in the same direction as triangle " + std::to_string(std::min(fs[i], fs[j])) +
                                   " (an edge of three triangles, or a flipped triangle)");
    // Walk the fan: from face (v, a, b) to the face starting with b.
    std::size_t steps = 0;
    std::int32_t f = fs.front();
    do {
      const std::int32_t b = after(f, after(f, v));
      const auto it = std::find_if(fs.begin(), fs.end(), [&](std::int32_t g) { return after(g, v) == b; });
      if (it == fs.end()) break;  // open fan: boundary vertex
      f = *it;
      ++steps;
    } while (f != fs.front() && steps <= fs.size());
    if (f != fs.front() || steps != fs.size()) state_[std::size_t(v)] |= kFixed;
  }

  static void erase(std::vector<std::int32_t>& v, std::int32_t x) {
    const auto it = std::find(v.begin(), v.end(), x);
    if (it != v.end()) {
      *it = v.back();
      v.pop_back();
    }
  }

  // Whether the edge v0-v1 may collapse (two faces on it, fl = (v0, v1, vl)
  // and fr = (v1, v0, vr), and the link condition); sets them.
  bool collapsible(Scratch& s, std::int32_t v0, std::int32_t v1, std::int32_t& fl, std::int32_t& fr, std::int32_t& vl,
                   std::int32_t& vr) {
    const auto& around = faces_of_[std::size_t(v0)];
    fl = -1, fr = -1, vl = -1, vr = -1;
    for (std::int32_t f : around) {
      const auto& t = tri_[std::size_t(f)];
      if (t[0] != v1 && t[1] != v1 && t[2] != v1) continue;
      if (after(f, v0) == v1)
        fl = f, vl = after(f, v1);
      else
        fr = f, vr = after(f, v0);
    }
    if (fl < 0 || fr < 0 || vl == vr) return false;
    // A valence-3 vl or vr would be left with two faces on the same three vertices.
    if (faces_of_[std::size_t(vl)].size() <= 3 || faces_of_[std::size_t(vr)].size() <= 3) return false;
    // Link condition: the rings of v0 and v1 share only vl and vr.
    ++s.stamp;
    for (std::int32_t f : faces_of_[std::size_t(v1)])
      for (std::int32_t w : tri_[std::size_t(f)]) mark_[std::size_t(w)] = s.stamp;
    for (std::int32_t f : around)
      for (std::int32_t w : tri_[std::size_t(f)])
        if (w != v0 && w != v1 && w != vl && w != vr && mark_[std::size_t(w)] == s.stamp) return false;
    return true;
  }

  // Collapses v0 into v1 if that is legal (decimate.h); returns whether it did.
  bool collapse(Scratch& s, std::int32_t v0, std::int32_t v1) {
    if (state_[std::size_t(v0)] & (kFixed | kBorder)) return false;
    const auto& around = faces_of_[std::size_t(v0)];
    std::int32_t fl, fr, vl, vr;
    if (!collapsible(s, v0, v1, fl, fr, vl, vr)) return false;

    // The surviving faces around v0 with v0 moved to v1: no normal turns by
    // more than the limit, none loses its area.
    const Vec3d& p1 = pos_[std::size_t(v1)];
    s.tris.clear();
    s.kept.clear();
    s.own.clear();
    for (std::int32_t f : around) {
      if (f == fl || f == fr) {
        s.own.push_back(-1);
        continue;
      }
      const auto& t = tri_[std::size_t(f)];
      const std::array<Vec3d, 3> o{pos_[std::size_t(t[0])], pos_[std::size_t(t[1])], pos_[std::size_t(t[2])]};
      std::array<Vec3d, 3> c = o;
      for (std::size_t k = 0; k < 3; ++k)
        if (t[k] == v0) c[k] = p1;
      const Vec3d n_old = (o[1] - o[0]).cross(o[2] - o[0]), n_new = (c[1] - c[0]).cross(c[2] - c[0]);
      const double new2 = n_new.squaredNorm(), old2 = n_old.squaredNorm();
      if (!(new2 > 0)) return false;
      if (old2 > 0 && n_old.dot(n_new) < cos_max_ * std::sqrt(old2 * new2)) return false;
      if (guard_angles_) {  // no new sliver; one already there may stay or improve
        const double now = least_angle(c[0], c[1], c[2]);
        if (now < min_angle_ && now < least_angle(o[0], o[1], o[2])) return false;
      }
      s.own.push_back(std::int32_t(s.tris.size()));
      s.kept.push_back(f);
      s.tris.emplace_back(c[0], c[1], c[2]);
    }
    // The bound: every piece held around v0 is covered by the new faces,
    // first tried against the face that holds it (usually enough: such a
    // piece stays where it is). The others are recorded with the face (or
    // faces, split) that covers them, to be moved there if legal.
    s.placed.clear();
    s.leaving.clear();
    auto record = [&](std::size_t k, const TrianglePiece& q) { s.placed.emplace_back(std::int32_t(k), key_of(q)); };
    for (std::size_t i = 0; i < around.size(); ++i) {
      const auto& held = pieces_[std::size_t(around[i])];
      const int own = s.own[i];
      for (std::size_t j = 0; j < held.size(); ++j) {
        const TrianglePiece q = expand_piece(held[j]);
        if (own >= 0 && s.cover.covered_by(s.tris[std::size_t(own)], q)) continue;
        if (!s.cover.cover(q, s.tris, own, false, record)) return false;
        if (own >= 0) s.leaving.emplace_back(own, std::uint32_t(j));
      }
    }

    // Legal: move the pieces that leave. Each face's pieces stay in
    // pre-order, so complete sets of four siblings held by one face merge
    // back into their parent in one pass (covered by that face too: its
    // corners are corners of the siblings), undoing splits for creases that
    // are gone.
    for (std::int32_t f : {fl, fr}) std::vector<PieceKey>().swap(pieces_[std::size_t(f)]);  // gone for good: free
    for (std::size_t i = 0; i < s.leaving.size();) {  // per face, ascending: compact in order
      const std::int32_t k = s.leaving[i].first;
      auto& held = pieces_[std::size_t(s.kept[std::size_t(k)])];
      std::size_t w = s.leaving[i].second;
      for (std::size_t r = w; r < held.size(); ++r)
        if (i < s.leaving.size() && s.leaving[i].first == k && s.leaving[i].second == r)
          ++i;
        else
          held[w++] = held[r];
      held.resize(w);
    }
    std::sort(s.placed.begin(), s.placed.end(), [](const auto& x, const auto& y) {
      return x.first != y.first ? x.first < y.first : preorder_less(x.second, y.second);
    });
    for (std::size_t i = 0; i < s.placed.size();) {  // per face: merge into its pieces from the back
      const std::int32_t k = s.placed[i].first;
      std::size_t end = i;
      bool deep = false;
      for (; end < s.placed.size() && s.placed[end].first == k; ++end) deep |= s.placed[end].second.depth > 0;
      auto& held = pieces_[std::size_t(s.kept[std::size_t(k)])];
      std::size_t old = held.size(), w = old + (end - i);
      held.resize(w);
      for (std::size_t j = end; j > i;) {
        const PieceKey& q = s.placed[j - 1].second;
        if (old > 0 && preorder_less(q, held[old - 1]))
          held[--w] = held[--old];
        else
          held[--w] = q, --j;
      }
      if (deep) merge_complete_siblings(held, w);  // held[w] is the first arrival
      i = end;
    }

    // Connectivity.
    for (std::int32_t f : {fl, fr}) {
      for (std::int32_t w : tri_[std::size_t(f)])
        if (w != v0) erase(faces_of_[std::size_t(w)], f);
      tri_[std::size_t(f)] = {-1, -1, -1};
    }
    auto& faces1 = faces_of_[std::size_t(v1)];
    for (std::int32_t f : s.kept) {
      for (auto& w : tri_[std::size_t(f)])
        if (w == v0) w = v1;
      faces1.push_back(f);
    }
    faces_of_[std::size_t(v0)] = {};
    quad_[std::size_t(v1)] += quad_[std::size_t(v0)];
    state_[std::size_t(v0)] |= kDead;
    state_[std::size_t(v1)] |= kTouched;
    for (std::int32_t f : faces1)
      for (std::int32_t w : tri_[std::size_t(f)]) changed(w);
    return true;
  }

  // Face f below the least angle: flips the edge whose flip lifts the pair's
  // least angle most (the two faces' pieces covered by the two new ones, as
  // for a collapse); failing that, collapses one of its edges, shortest
  // first; failing that, moves a vertex (collapse_inside, drop_cap, relax).
  void lift_sliver(Scratch& s, std::int32_t f) {
    const auto t = tri_[std::size_t(f)];
    const double was = least_angle(pos_[std::size_t(t[0])], pos_[std::size_t(t[1])], pos_[std::size_t(t[2])]);
    if (was >= min_angle_) return;
    const std::uint64_t around = neighbourhood(t);
    if (around != 0 && stuck_[std::size_t(f)] == around) return;  // failed before, nothing near it changed since
    struct Flip {
      std::int32_t g = -1, a = 0, b = 0, c = 0, d = 0;
      double angle = 0;
    } best;
    for (std::size_t k = 0; k < 3; ++k) {
      const std::int32_t a = t[k], b = t[(k + 1) % 3], c = t[(k + 2) % 3];
      const std::int32_t g = face_with_edge(b, a);
      if (g < 0) continue;
      const std::int32_t d = after(g, a);
      if (!flip_legal(a, b, c, d)) continue;
      const auto& q = tri_[std::size_t(g)];
      const double old_pair =
          std::min(was, least_angle(pos_[std::size_t(q[0])], pos_[std::size_t(q[1])], pos_[std::size_t(q[2])]));
      const double new_pair = std::min(least_angle(pos_[std::size_t(c)], pos_[std::size_t(a)], pos_[std::size_t(d)]),
                                       least_angle(pos_[std::size_t(d)], pos_[std::size_t(b)], pos_[std::size_t(c)]));
      if (new_pair > old_pair && new_pair > best.angle) best = {g, a, b, c, d, new_pair};
    }
    if (best.g >= 0 && flip(s, f, best.g, best.a, best.b, best.c, best.d)) return;
    // Else collapse one of its edges away, shortest first.
    std::array<std::size_t, 3> order{0, 1, 2};
    auto length2 = [&](std::size_t k) { return (pos_[std::size_t(t[k])] - pos_[std::size_t(t[(k + 1) % 3])]).squaredNorm(); };
    std::sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) { return length2(x) < length2(y); });
    for (std::size_t k : order) {
      const std::int32_t a = t[k], b = t[(k + 1) % 3];
      if ((state_[std::size_t(a)] | state_[std::size_t(b)]) & (kDead | kTouched)) continue;
      if (collapse(s, a, b) || collapse(s, b, a)) {
        ++sliver_collapses_;
        return;
      }
    }
    // Else move a vertex: an edge into a point inside it, the apex onto the
    // long edge, a corner towards its ring's centroid.
    if (collapse_inside(s, t, order) || drop_cap(s, f) || relax(s, t))
      ++sliver_moves_;
    else
      stuck_[std::size_t(f)] = around;
  }

  // Vertex w's neighbourhood changed: its edges are candidates again, and
  // its version (min_angle_deg) moves on.
  void changed(std::int32_t w) {
    state_[std::size_t(w)] |= kDirty;
    if (!version_.empty()) ++version_[std::size_t(w)];
  }

  // A hash of the versions of the corners of the faces around t's corners:
  // what a sliver's lifting looks at; 0 if one is kTouched (held this pass only).
  [[nodiscard]] std::uint64_t neighbourhood(const std::array<std::int32_t, 3>& t) const {
    std::uint64_t h = 14695981039346656037ull;  // FNV-1a
    for (std::int32_t v : t)
      for (std::int32_t g : faces_of_[std::size_t(v)])
        for (std::int32_t w : tri_[std::size_t(g)]) {
          if (state_[std::size_t(w)] & kTouched) return 0;
          h = (h ^ (std::uint64_t(w) << 32 | version_[std::size_t(w)])) * 1099511628211ull;
        }
    return h;
  }

  // A position rounded to float (the output's precision) before it is certified.
  static Vec3d representable(const Vec3d& p) { return p.cast<float>().cast<double>(); }

  // Collapses an edge of t (in `order`, k: t[k]-t[k+1]) into a point near
  // it: on it (the merged quadric's least point there, the midpoint), the
  // quadric's least point anywhere if near, or around the midpoint.
  bool collapse_inside(Scratch& s, const std::array<std::int32_t, 3>& t, const std::array<std::size_t, 3>& order) {
    for (std::size_t k : order) {
      const std::int32_t a = t[k], b = t[(k + 1) % 3];
      if ((state_[std::size_t(a)] | state_[std::size_t(b)]) & (kFixed | kDead | kTouched)) continue;
      std::int32_t fl, fr, vl, vr;
      if (!collapsible(s, a, b, fl, fr, vl, vr)) continue;
      Quadric q = quad_[std::size_t(a)];
      q += quad_[std::size_t(b)];
      const Vec3d pa = pos_[std::size_t(a)], pb = pos_[std::size_t(b)], mid = 0.5 * (pa + pb);
      Vec3d n = Vec3d::Zero();
      s.changes.clear();
      for (std::int32_t h : faces_of_[std::size_t(a)]) {
        auto now = tri_[std::size_t(h)];
        if (h == fl || h == fr)
          now = {-1, -1, -1};
        else
          for (auto& w : now) w = w == a ? b : w;
        s.changes.push_back({h, now, normal_of(h)});
        n += normal_of(h);
      }
      for (std::int32_t h : faces_of_[std::size_t(b)])
        if (h != fl && h != fr) {
          s.changes.push_back({h, tri_[std::size_t(h)], normal_of(h)});
          n += normal_of(h);
        }
      // q along the edge is the parabola through its values at 0, 1/2, 1.
      const double q0 = q(pa), qm = q(mid), q1 = q(pb);
      const double curve = 2 * (q0 + q1) - 4 * qm, slope = 4 * qm - 3 * q0 - q1;
      const double least = curve > 0 ? std::clamp(-slope / (2 * curve), 0.0, 1.0) : 0.5;
      std::vector<Vec3d> seeds{mid};
      if (least > 0 && least < 1) seeds.push_back(pa + least * (pb - pa));
      Eigen::Matrix3d m;
      m << q.a11, q.a12, q.a13, q.a12, q.a22, q.a23, q.a13, q.a23, q.a33;
      const auto lu = m.fullPivLu();
      if (lu.isInvertible()) {
        const Vec3d best = lu.solve(-Vec3d(q.a14, q.a24, q.a34));
        if ((best - mid).norm() <= (pb - pa).norm()) seeds.push_back(best);
      }
      if (move_best(s, b, a, q, n, kRelaxReach * (pb - pa).norm(), seeds, &mid)) return true;
    }
    return false;
  }

  // Cap f = (a, b, c) with a-b its longest edge: flips a-b to c-d and moves c
  // towards a-b (its foot or the midpoint), splitting the face beyond in two.
  bool drop_cap(Scratch& s, std::int32_t f) {
    const auto t = tri_[std::size_t(f)];
    std::size_t k = 0;
    for (std::size_t j = 1; j < 3; ++j)
      if ((pos_[std::size_t(t[(j + 1) % 3])] - pos_[std::size_t(t[j])]).squaredNorm() >
          (pos_[std::size_t(t[(k + 1) % 3])] - pos_[std::size_t(t[k])]).squaredNorm())
        k = j;
    const std::int32_t a = t[k], b = t[(k + 1) % 3], c = t[(k + 2) % 3];
    const std::int32_t g = face_with_edge(b, a);
    if (g < 0 || (state_[std::size_t(c)] & kTouched)) return false;
    const std::int32_t d = after(g, a);
    if (!flippable(a, b, c, d)) return false;
    const Vec3d &pa = pos_[std::size_t(a)], &pb = pos_[std::size_t(b)], &pc = pos_[std::size_t(c)],
                &pd = pos_[std::size_t(d)];
    const Vec3d pair = (pb - pa).cross(pc - pa) + (pa - pb).cross(pd - pb);
    Vec3d n = pair;
    s.changes.clear();
    s.changes.push_back({f, {c, a, d}, pair});
    s.changes.push_back({g, {d, b, c}, pair});
    for (std::int32_t h : faces_of_[std::size_t(c)])
      if (h != f) {
        s.changes.push_back({h, tri_[std::size_t(h)], normal_of(h)});
        n += normal_of(h);
      }
    const Vec3d foot = pa + std::clamp((pc - pa).dot(pb - pa) / (pb - pa).squaredNorm(), 0.0, 1.0) * (pb - pa);
    std::vector<Vec3d> seeds;
    for (double u : kCapSteps) seeds.push_back(pc + u * (foot - pc));
    seeds.push_back(0.5 * (pa + pb));
    return move_best(s, c, -1, quad_[std::size_t(c)], n, (foot - pc).norm(), seeds, nullptr);
  }

  // Moves a corner of t within its tangent plane: towards its ring's
  // centroid, or around where it is (move_best).
  bool relax(Scratch& s, const std::array<std::int32_t, 3>& t) {
    for (std::int32_t v : t) {
      if (state_[std::size_t(v)] & (kFixed | kDead | kTouched)) continue;
      const auto& fan = faces_of_[std::size_t(v)];
      const Vec3d p = pos_[std::size_t(v)];
      Vec3d centroid = Vec3d::Zero(), n = Vec3d::Zero();
      double nearest = std::numeric_limits<double>::infinity();
      s.changes.clear();
      for (std::int32_t h : fan) {
        const Vec3d& w = pos_[std::size_t(after(h, v))];
        centroid += w;
        nearest = std::min(nearest, (w - p).norm());
        n += normal_of(h);
        s.changes.push_back({h, tri_[std::size_t(h)], normal_of(h)});
      }
      if (!(n.squaredNorm() > 0)) continue;
      Vec3d step = centroid / double(fan.size()) - p;
      step -= n * (n.dot(step) / n.squaredNorm());
      std::vector<Vec3d> seeds;
      for (double u : kRelaxSteps) seeds.push_back(p + u * step);
      if (move_best(s, v, -1, quad_[std::size_t(v)], n, kRelaxReach * nearest, seeds, &p)) return true;
    }
    return false;
  }

  // Moves `moved` (merging `gone` into it if >= 0; s.changes: the faces that
  // change) to the best of: each seed, the points kRelaxSteps of `reach`
  // from `around` (if given) in kRelaxDirections tangent directions, and
  // each of these lifted along n (the fan's normal) to the least of q; those
  // judge() allows are tried against the bound, the largest gain first.
  bool move_best(Scratch& s, std::int32_t moved, std::int32_t gone, const Quadric& q, Vec3d n, double reach,
                 std::vector<Vec3d> seeds, const Vec3d* around) {
    if (!(n.squaredNorm() > 0)) return false;
    n.normalize();
    if (around) {
      const Vec3d e1 = n.unitOrthogonal(), e2 = n.cross(e1);
      for (int k = 0; k < kRelaxDirections; ++k) {
        const double phi = 2 * std::numbers::pi * k / kRelaxDirections;
        for (double u : kRelaxSteps) seeds.push_back(*around + u * reach * (std::cos(phi) * e1 + std::sin(phi) * e2));
      }
    }
    const Gain was = gain_now(s);  // the same for every candidate
    std::vector<std::pair<Gain, Vec3d>> tries;
    for (const Vec3d& seed : seeds)
      for (const Vec3d& x : {seed, lifted(q, seed, n, reach)}) {
        const Vec3d at = representable(x);
        if (const auto g = judge(s, was, moved, at)) tries.emplace_back(*g, at);
      }
    std::stable_sort(tries.begin(), tries.end(), [](const auto& x, const auto& y) { return x.first.better(y.first); });
    for (const auto& tried : tries)
      if (reshape(s, was, moved, tried.second, gone)) return true;
    return false;
  }

  // x moved along the unit n, by at most `reach`, to the least of q on that line.
  static Vec3d lifted(const Quadric& q, const Vec3d& x, const Vec3d& n, double reach) {
    const double q0 = q(x), up = q(x + n), down = q(x - n);
    const double curve = up + down - 2 * q0;
    return curve > 0 ? Vec3d(x + std::clamp((down - up) / (2 * curve), -reach, reach) * n) : x;
  }

  // Twice the area times the unit normal of face h.
  [[nodiscard]] Vec3d normal_of(std::int32_t h) const {
    const auto& t = tri_[std::size_t(h)];
    const Vec3d& a = pos_[std::size_t(t[0])];
    return (pos_[std::size_t(t[1])] - a).cross(pos_[std::size_t(t[2])] - a);
  }

  // Faces below the least angle and the least angle among s.changes' faces.
  struct Gain {
    long below = 0;
    double least = std::numeric_limits<double>::infinity();
    [[nodiscard]] bool better(const Gain& o) const { return below != o.below ? below < o.below : least > o.least; }
  };

  // The angles of s.changes' faces as they are.
  [[nodiscard]] Gain gain_now(const Scratch& s) const {
    Gain g;
    for (const Change& c : s.changes) {
      const auto& o = tri_[std::size_t(c.face)];
      const double a = least_angle(pos_[std::size_t(o[0])], pos_[std::size_t(o[1])], pos_[std::size_t(o[2])]);
      g.below += a < min_angle_;
      g.least = std::min(g.least, a);
    }
    return g;
  }

  // s.changes with `moved` at `to`, if no face degenerates or turns from its
  // reference normal by more than the limit and the angles improve on `was`
  // (gain_now(): fewer faces below the least angle, or as many with the
  // least larger): the new angles, and the new faces in s.tris (s.own: index
  // per change, -1 gone).
  std::optional<Gain> judge(Scratch& s, const Gain& was, std::int32_t moved, const Vec3d& to) {
    if (to == pos_[std::size_t(moved)]) return std::nullopt;
    auto at = [&](std::int32_t v) -> const Vec3d& { return v == moved ? to : pos_[std::size_t(v)]; };
    Gain now;
    s.tris.clear();
    s.own.clear();
    for (const Change& c : s.changes) {
      if (c.now[0] < 0) {
        s.own.push_back(-1);
        continue;
      }
      const Vec3d &p0 = at(c.now[0]), &p1 = at(c.now[1]), &p2 = at(c.now[2]);
      const Vec3d n = (p1 - p0).cross(p2 - p0);
      const double n2 = n.squaredNorm(), r2 = c.normal.squaredNorm();
      if (!(n2 > 0) || (r2 > 0 && n.dot(c.normal) < cos_max_ * std::sqrt(n2 * r2))) return std::nullopt;
      const double shaped = least_angle(p0, p1, p2);
      now.below += shaped < min_angle_;
      now.least = std::min(now.least, shaped);
      s.own.push_back(std::int32_t(s.tris.size()));
      s.tris.emplace_back(p0, p1, p2);
    }
    if (!now.better(was)) return std::nullopt;
    return now;
  }

  // Applies s.changes (every face whose corners change or move) with vertex
  // `moved` at `to` and `gone` (if >= 0) removed, if judge() allows it and
  // the new faces cover every piece of the old (as for a collapse). Returns
  // whether it did.
  bool reshape(Scratch& s, const Gain& was, std::int32_t moved, const Vec3d& to, std::int32_t gone) {
    if (!judge(s, was, moved, to)) return false;
    s.placed.clear();
    auto record = [&](std::size_t k, const TrianglePiece& q) { s.placed.emplace_back(std::int32_t(k), key_of(q)); };
    for (std::size_t i = 0; i < s.changes.size(); ++i)
      for (const PieceKey& key : pieces_[std::size_t(s.changes[i].face)])
        if (!s.cover.cover(expand_piece(key), s.tris, s.own[i], false, record)) return false;

    std::vector<std::vector<PieceKey>> held(s.tris.size());
    for (const auto& [k, key] : s.placed) held[std::size_t(k)].push_back(key);
    for (auto& h : held) coarsen(h);
    auto has = [](const std::array<std::int32_t, 3>& t, std::int32_t v) { return t[0] == v || t[1] == v || t[2] == v; };
    for (std::size_t i = 0; i < s.changes.size(); ++i) {
      const Change& c = s.changes[i];
      const auto was = tri_[std::size_t(c.face)];
      for (std::int32_t w : was)
        if (!has(c.now, w)) erase(faces_of_[std::size_t(w)], c.face);
      for (std::int32_t w : c.now)
        if (w >= 0 && !has(was, w)) faces_of_[std::size_t(w)].push_back(c.face);
      for (std::int32_t w : was) changed(w);
      tri_[std::size_t(c.face)] = c.now;
      if (s.own[i] >= 0)
        pieces_[std::size_t(c.face)] = std::move(held[std::size_t(s.own[i])]);
      else
        std::vector<PieceKey>().swap(pieces_[std::size_t(c.face)]);
    }
    if (gone >= 0) {
      quad_[std::size_t(moved)] += quad_[std::size_t(gone)];
      state_[std::size_t(gone)] |= kDead;
    }
    pos_[std::size_t(moved)] = to;
    state_[std::size_t(moved)] |= kTouched | kDirty;
    for (std::int32_t h : faces_of_[std::size_t(moved)])
      for (std::int32_t w : tri_[std::size_t(h)]) changed(w);
    return true;
  }

  // A piece with its corners on its input triangle (input_ once vertices move).
  [[nodiscard]] TrianglePiece expand_piece(const PieceKey& key) const {
    const auto& t = original_[key.triangle];
    const std::vector<Vec3d>& at = input_.empty() ? pos_ : input_;
    return expand(key, at[std::size_t(t[0])], at[std::size_t(t[1])], at[std::size_t(t[2])]);
  }

  // The face holding the directed edge u->w, or -1.
  [[nodiscard]] std::int32_t face_with_edge(std::int32_t u, std::int32_t w) const {
    for (std::int32_t g : faces_of_[std::size_t(u)])
      if (after(g, u) == w) return g;
    return -1;
  }

  // The connectivity part of flip_legal().
  [[nodiscard]] bool flippable(std::int32_t a, std::int32_t b, std::int32_t c, std::int32_t d) const {
    for (std::int32_t v : {a, b, c, d})
      if (state_[std::size_t(v)] & (kFixed | kDead)) return false;
    if (c == d || faces_of_[std::size_t(a)].size() <= 3 || faces_of_[std::size_t(b)].size() <= 3) return false;
    return face_with_edge(c, d) < 0 && face_with_edge(d, c) < 0;
  }

  // Faces f = (a, b, c) and g = (b, a, d) may become (c, a, d) and (d, b, c):
  // no moved or held vertex, no edge c-d already, a and b keep three faces,
  // neither new face turns from the pair's normal by more than the limit.
  [[nodiscard]] bool flip_legal(std::int32_t a, std::int32_t b, std::int32_t c, std::int32_t d) const {
    if (!flippable(a, b, c, d)) return false;
    const Vec3d &pa = pos_[std::size_t(a)], &pb = pos_[std::size_t(b)], &pc = pos_[std::size_t(c)],
                &pd = pos_[std::size_t(d)];
    const Vec3d pair = (pb - pa).cross(pc - pa) + (pa - pb).cross(pd - pb);
    for (const Vec3d& n : {Vec3d((pa - pc).cross(pd - pc)), Vec3d((pb - pd).cross(pc - pd))}) {
      const double n2 = n.squaredNorm();
      if (!(n2 > 0) || n.dot(pair) < cos_max_ * std::sqrt(n2 * pair.squaredNorm())) return false;
    }
    return true;
  }

  // Flips the edge a-b of f = (a, b, c), g = (b, a, d) if the new faces cover
  // both faces' pieces; returns whether it did.
  bool flip(Scratch& s, std::int32_t f, std::int32_t g, std::int32_t a, std::int32_t b, std::int32_t c,
            std::int32_t d) {
    s.tris.clear();
    s.tris.emplace_back(pos_[std::size_t(c)], pos_[std::size_t(a)], pos_[std::size_t(d)]);
    s.tris.emplace_back(pos_[std::size_t(d)], pos_[std::size_t(b)], pos_[std::size_t(c)]);
    s.placed.clear();
    auto record = [&](std::size_t k, const TrianglePiece& q) { s.placed.emplace_back(std::int32_t(k), key_of(q)); };
    for (std::int32_t h : {f, g})
      for (const PieceKey& key : pieces_[std::size_t(h)])
        if (!s.cover.cover(expand_piece(key), s.tris, -1, false, record)) return false;
    std::array<std::vector<PieceKey>, 2> held;
    for (const auto& [k, key] : s.placed) held[std::size_t(k)].push_back(key);
    for (auto& h : held) coarsen(h);
    pieces_[std::size_t(f)] = std::move(held[0]);
    pieces_[std::size_t(g)] = std::move(held[1]);
    tri_[std::size_t(f)] = {c, a, d};
    tri_[std::size_t(g)] = {d, b, c};
    erase(faces_of_[std::size_t(a)], g);
    erase(faces_of_[std::size_t(b)], f);
    faces_of_[std::size_t(c)].push_back(g);
    faces_of_[std::size_t(d)].push_back(f);
    for (std::int32_t v : {a, b, c, d}) changed(v);
    ++flips_;
    return true;
  }

  std::vector<Vec3d> pos_;
  std::vector<std::array<std::int32_t, 3>> tri_;  // {-1, -1, -1}: collapsed away
  std::vector<std::vector<std::int32_t>> faces_of_;
  std::vector<Quadric> quad_;
  std::vector<std::uint8_t> state_;
  std::vector<unsigned> mark_;  // == Scratch::stamp: marked in the current collapse
  std::vector<std::array<std::int32_t, 3>> original_;  // the input triangles: corners of the pieces
  std::vector<std::vector<PieceKey>> pieces_;  // held by each face
  std::vector<Vec3d> input_;  // the input positions, kept once vertices may move (min_angle_deg); else pos_
  std::vector<std::uint32_t> version_;  // per vertex: changes of its neighbourhood (min_angle_deg)
  std::vector<std::uint64_t> stuck_;    // per face: neighbourhood() when its lifting last failed, else 0
  double tolerance_, cos_max_, min_angle_;
  bool guard_angles_ = false;  // collapses make no new sliver (after the first rounds)
  long flips_ = 0, sliver_collapses_ = 0, sliver_moves_ = 0;
};

}  // namespace
}  // namespace detail

DecimateResult detail::decimate_in_slabs(TriMesh& mesh, const DecimateParams& params, std::size_t slabs) {
  validate_decimate_input(mesh, params);
  const long before = long(mesh.triangles.size());
  if (params.max_error == 0 || before == 0) return {before, before};
  FastDecimator d(mesh, params);
  mesh = {};  // d holds its own copy: free this one while decimating
  d.run(std::max<std::size_t>(slabs, 1));
  mesh = d.result();
  return {before, long(mesh.triangles.size()), d.flips(), d.sliver_collapses(), d.sliver_moves()};
}

DecimateResult decimate(TriMesh& mesh, const DecimateParams& params) {
  const std::size_t slabs = std::clamp<std::size_t>(mesh.triangles.size() / detail::kTrianglesPerSlab, 1, detail::kMaxSlabs);
  return detail::decimate_in_slabs(mesh, params, slabs);
}

}  // namespace isoloft
