// @file mesh/decimate_bound.h
// @brief The decimation bound (mesh/decimate.h), shared with its reference.
// Every original triangle, or a piece of its midpoint subdivision, is held by
// one face covering it (each corner within the bound); a collapse must
// re-cover the pieces of the faces it changes, splitting what no face covers.
#pragma once

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>
#include <limits>
#include <tuple>
#include <vector>

#include "isoloft/core/mesh.h"
#include "isoloft/mesh/decimate.h"

namespace isoloft::detail {

// A triangle prepared for squared-distance queries.
// @warning A zero-area triangle gives the distance to its nearest side.
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

// A piece of an original triangle. Bit k of `original`: corner k is an
// original vertex, held to max_error itself (the others get the slack).
// `path`: child indices (split()) from the top, 2 bits each, last lowest.
struct TrianglePiece {
  std::array<Vec3d, 3> p;
  std::uint32_t triangle = 0;
  std::uint8_t original = 0;
  std::uint8_t depth = 0;
  std::uint64_t path = 0;
};
inline constexpr int kMaxPieceDepth = 31;  // 2 bits per level in TrianglePiece::path

// Child k of the midpoint subdivision (k < 3 keeps corner k).
inline TrianglePiece child(const TrianglePiece& q, unsigned k) {
  const Vec3d m01 = 0.5 * (q.p[0] + q.p[1]), m12 = 0.5 * (q.p[1] + q.p[2]), m20 = 0.5 * (q.p[2] + q.p[0]);
  const std::uint8_t d = q.depth + 1;
  const std::uint64_t path = q.path << 2 | k;
  switch (k) {
    case 0: return TrianglePiece{{q.p[0], m01, m20}, q.triangle, std::uint8_t(q.original & 1u), d, path};
    case 1: return TrianglePiece{{m01, q.p[1], m12}, q.triangle, std::uint8_t(q.original & 2u), d, path};
    case 2: return TrianglePiece{{m20, m12, q.p[2]}, q.triangle, std::uint8_t(q.original & 4u), d, path};
    default: return TrianglePiece{{m01, m12, m20}, q.triangle, 0u, d, path};
  }
}

inline std::array<TrianglePiece, 4> split(const TrianglePiece& q) { return {child(q, 0), child(q, 1), child(q, 2), child(q, 3)}; }

// A piece without corners (16 bytes); expand() recomputes them bit for bit.
struct PieceKey {
  std::uint64_t path = 0;
  std::uint32_t triangle = 0;
  std::uint8_t original = 0;
  std::uint8_t depth = 0;
};

inline PieceKey key_of(const TrianglePiece& q) { return {q.path, q.triangle, q.original, q.depth}; }

inline TrianglePiece expand(const PieceKey& key, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  TrianglePiece q{{a, b, c}, key.triangle, 7u, 0u, 0u};
  for (int level = int(key.depth) - 1; level >= 0; --level) q = child(q, unsigned(key.path >> (2 * level)) & 3u);
  return q;
}

// The parent of siblings a, b, c (children 0-2).
inline TrianglePiece parent_of(const TrianglePiece& a, const TrianglePiece& b, const TrianglePiece& c) {
  return TrianglePiece{{a.p[0], b.p[1], c.p[2]}, a.triangle, std::uint8_t(a.original | b.original | c.original),
               std::uint8_t(a.depth - 1), a.path >> 2};
}
inline PieceKey parent_of(const PieceKey& a, const PieceKey& b, const PieceKey& c) {
  return PieceKey{a.path >> 2, a.triangle, std::uint8_t(a.original | b.original | c.original), std::uint8_t(a.depth - 1)};
}

// Pre-order (triangle, then path from the top): siblings end up adjacent.
template <class P>  // TrianglePiece or PieceKey
[[nodiscard]] bool preorder_less(const P& a, const P& b) {
  auto top_down = [](const P& q) { return q.path << (2 * (kMaxPieceDepth - q.depth)); };
  return a.triangle != b.triangle ? a.triangle < b.triangle : top_down(a) < top_down(b);
}

// Replaces every complete set of four siblings by their parent, bottom up, in
// one pass. \pre pre-order, no set complete before `from`; both stay so.
template <class P>
void merge_complete_siblings(std::vector<P>& pieces, std::size_t from = 0) {  // pieces before `from`: done
  std::size_t w = from;
  for (std::size_t r = from; r < pieces.size(); ++r) {
    pieces[w++] = pieces[r];
    while (w >= 4) {
      const P &a = pieces[w - 4], &b = pieces[w - 3], &c = pieces[w - 2], &d = pieces[w - 1];
      auto sibling = [&](const P& q, std::uint64_t k) {
        return q.triangle == d.triangle && q.depth == d.depth && q.path == ((d.path & ~std::uint64_t(3)) | k);
      };
      if (d.depth == 0 || (d.path & 3u) != 3u || !sibling(a, 0) || !sibling(b, 1) || !sibling(c, 2)) break;
      pieces[w - 4] = parent_of(a, b, c);
      w -= 3;
    }
  }
  pieces.resize(w);
}

// merge_complete_siblings() on pieces in any order (the reference).
template <class P>
void coarsen(std::vector<P>& pieces) {
  std::sort(pieces.begin(), pieces.end(), preorder_less<P>);
  merge_complete_siblings(pieces);
}

// Covers pieces by the faces a collapse changes (in their new shape).
class PieceCover {
 public:
  explicit PieceCover(double tolerance)
      : vertex_tol2_(tolerance * tolerance),
        surface_tol2_((tolerance + kDecimateSurfaceSlack) * (tolerance + kDecimateSurfaceSlack)) {}

  [[nodiscard]] bool covered_by(const PreparedTriangle& t, const TrianglePiece& q) const {
    for (std::size_t k = 0; k < 3; ++k)
      if (t.distance_sq(q.p[k]) > ((q.original >> k & 1u) ? vertex_tol2_ : surface_tol2_)) return false;
    return true;
  }

  // Covers `piece` by faces of tris, splitting it where no face does; place(k,
  // part) per covered part (k: the first covering face, `hint` first; with
  // `best`, the one of least largest corner distance). \return false (illegal)
  // if an uncovered part has a corner beyond its bound from every face, or is
  // small (side <= kDecimateSurfaceSlack, <= 1 original corner).
  template <class Place>
  bool cover(const TrianglePiece& piece, const std::vector<PreparedTriangle>& tris, int hint, bool best, Place&& place) {
    constexpr double kInf = std::numeric_limits<double>::infinity();
    const double smallest2 = kDecimateSurfaceSlack * kDecimateSurfaceSlack;
    const std::size_t n = tris.size();
    stack_.assign(1, piece);
    while (!stack_.empty()) {
      const TrianglePiece q = stack_.back();
      stack_.pop_back();
      std::array<double, 3> bound{};
      for (std::size_t k = 0; k < 3; ++k) bound[k] = (q.original >> k & 1u) ? vertex_tol2_ : surface_tol2_;
      unsigned reached = 0;   // bit k: corner k is within its bound of some face
      tested_.assign(n, 0u);  // bit k of tested_[j]: corner k measured against face j
      auto covers = [&](std::size_t j, double& worst) {
        worst = 0;
        for (std::size_t k = 0; k < 3; ++k) {
          const double d = tris[j].distance_sq(q.p[k]);
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
          if (!(tested_[j] >> k & 1u) && tris[j].distance_sq(q.p[k]) <= bound[k]) rejected = false;
      }
      const double side2 =
          std::max({(q.p[1] - q.p[0]).squaredNorm(), (q.p[2] - q.p[1]).squaredNorm(), (q.p[0] - q.p[2]).squaredNorm()});
      if (rejected || (side2 <= smallest2 && std::popcount(unsigned(q.original)) <= 1) || q.depth == kMaxPieceDepth) {
        if (!best) return false;
        std::size_t nearest = 0;  // unreachable when placing: keep the part
        double nearest_d = kInf;
        for (std::size_t j = 0; j < n; ++j) {
          double dj = 0;
          for (const Vec3d& p : q.p) dj = std::max(dj, tris[j].distance_sq(p));
          if (dj < nearest_d) nearest_d = dj, nearest = j;
        }
        place(nearest, q);
        continue;
      }
      for (const TrianglePiece& part : split(q)) stack_.push_back(part);
    }
    return true;
  }

 private:
  double vertex_tol2_, surface_tol2_;
  std::vector<TrianglePiece> stack_;
  std::vector<unsigned> tested_;
};

// Area-weighted plane quadric: Q(p) = sum area (n.p + d)^2.
struct Quadric {
  double a11 = 0, a12 = 0, a13 = 0, a14 = 0, a22 = 0, a23 = 0, a24 = 0, a33 = 0, a34 = 0, a44 = 0;
  static Quadric plane(const Vec3d& n, double d, double weight) {
    return {weight * n.x() * n.x(), weight * n.x() * n.y(), weight * n.x() * n.z(), weight * n.x() * d,
            weight * n.y() * n.y(), weight * n.y() * n.z(), weight * n.y() * d,     weight * n.z() * n.z(),
            weight * n.z() * d,     weight * d * d};
  }
  Quadric& operator+=(const Quadric& o) {
    a11 += o.a11, a12 += o.a12, a13 += o.a13, a14 += o.a14, a22 += o.a22;
    a23 += o.a23, a24 += o.a24, a33 += o.a33, a34 += o.a34, a44 += o.a44;
    return *this;
  }
  [[nodiscard]] double operator()(const Vec3d& p) const {
    const double x = p.x(), y = p.y(), z = p.z();
    return x * (a11 * x + 2 * (a12 * y + a13 * z + a14)) + y * (a22 * y + 2 * (a23 * z + a24)) +
           z * (a33 * z + 2 * a34) + a44;
  }
};

/// The checks of decimate.h \throw, shared by both decimators.
void validate_decimate_input(const TriMesh& mesh, const DecimateParams& params);

}  // namespace isoloft::detail
