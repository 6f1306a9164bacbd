#include "isoloft/mesh/mesh_check.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_reduce.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cstdint>
#include <numeric>
#include <string>
#include <vector>

#include "isoloft/core/error.h"

namespace isoloft {

namespace {

// Vertices per task of the star pass: ~1 ms of work each.
constexpr std::size_t kStarVertices = 16384;

// Most triangles around a vertex the star pass's fast path takes (a bit
// mask of them); a Marching Cubes vertex has at most ~12.
constexpr std::uint32_t kFastStar = 32;

// The star of a vertex v as most are in a closed oriented manifold: each
// triangle (v, a, b) holds v once and a != b, and the map from each triangle
// to the one whose b is its a is a permutation (then the a are distinct, the
// b are distinct, and each edge (v, w) is in exactly two triangles, once in
// each direction). Its fans are the permutation's cycles. False: not so
// (the general count decides).
bool fast_star(std::uint32_t v, const std::uint32_t* incident, std::uint32_t n,
               const std::vector<std::array<std::int32_t, 3>>& triangles, bool& one_fan, long& edges) {
  if (n > kFastStar) return false;
  std::uint32_t a[kFastStar], b[kFastStar];
  for (std::uint32_t k = 0; k < n; ++k) {
    const auto& t = triangles[incident[k]];
    const int p = std::uint32_t(t[0]) == v ? 0 : std::uint32_t(t[1]) == v ? 1 : 2;
    a[k] = std::uint32_t(t[(p + 1) % 3]), b[k] = std::uint32_t(t[(p + 2) % 3]);
    if (a[k] == v || b[k] == v || a[k] == b[k]) return false;
  }
  std::uint8_t next[kFastStar];
  std::uint32_t hit = 0;
  long larger = 0;
  for (std::uint32_t k = 0; k < n; ++k) {
    std::uint32_t j = 0;
    while (j < n && b[j] != a[k]) ++j;
    if (j == n || (hit >> j & 1u)) return false;
    hit |= 1u << j;
    next[k] = std::uint8_t(j);
    larger += a[k] > v;
  }
  std::uint32_t cycle = 1;
  for (std::uint32_t k = next[0]; k != 0; k = next[k]) ++cycle;
  one_fan = cycle == n;
  edges = larger;
  return true;
}

struct UnionFind {
  std::vector<std::int32_t> parent;
  UnionFind() = default;
  explicit UnionFind(std::size_t n) { reset(n); }
  void reset(std::size_t n) {  // n elements, each its own set (the storage kept)
    parent.resize(n);
    std::iota(parent.begin(), parent.end(), 0);
  }
  std::int32_t find(std::int32_t a) {
    while (parent[std::size_t(a)] != a) a = parent[std::size_t(a)] = parent[std::size_t(parent[std::size_t(a)])];
    return a;
  }
  bool unite(std::int32_t a, std::int32_t b) {
    a = find(a), b = find(b);
    if (a == b) return false;
    parent[std::size_t(std::max(a, b))] = std::min(a, b);
    return true;
  }
};

}  // namespace

MeshCheck check_mesh(const TriMesh& mesh) {
  MeshCheck r;
  const std::size_t nv = mesh.vertices.size(), nf = mesh.triangles.size();
  for (std::size_t f = 0; f < nf; ++f)
    for (std::int32_t v : mesh.triangles[f])
      if (v < 0 || std::size_t(v) >= nv)
        throw InputError("", "mesh check: triangle " + std::to_string(f) + " references vertex " + std::to_string(v) +
                                 " of " + std::to_string(nv));

  // Three independent passes side by side, each in its own (serial) order,
  // so the figures are those of running them one after another.
  long edges = 0, used_vertices = 0;
  auto geometry = [&] {  // area and divergence-theorem volume, in double
    for (std::size_t f = 0; f < nf; ++f) {
      const auto& t = mesh.triangles[f];
      const Vec3d a = mesh.vertices[std::size_t(t[0])].cast<double>(), b = mesh.vertices[std::size_t(t[1])].cast<double>(),
                  c = mesh.vertices[std::size_t(t[2])].cast<double>();
      const Vec3d n = (b - a).cross(c - a);
      r.area += 0.5 * n.norm();
      r.volume += a.dot(b.cross(c)) / 6.0;
      if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || n.squaredNorm() == 0.0) ++r.degenerate_triangles;
    }
  };
  auto star_pass = [&] {
    // Per vertex v, from the triangles around it (incidence lists in CSR form):
    // its star, which must form a single fan (triangles joined when they share
    // an edge (v, w)), and the edges (v, w) with w > v, each counted once by
    // its smaller vertex: the triangles traversing it and in which direction.
    std::vector<std::uint32_t> start(nv + 1, 0);
    for (const auto& t : mesh.triangles)
      for (std::int32_t v : t) ++start[std::size_t(v) + 1];
    std::partial_sum(start.begin(), start.end(), start.begin());
    std::vector<std::uint32_t> incident(start.back()), fill(start.begin(), start.end() - 1);
    for (std::size_t f = 0; f < nf; ++f)
      for (std::int32_t v : mesh.triangles[f]) incident[fill[std::size_t(v)]++] = std::uint32_t(f);
    fill = {};
    // Vertex blocks side by side: the counts are sums.
    struct Counts {
      long used = 0, nonmanifold = 0, edges = 0, boundary = 0, nonmanifold_edges = 0, inconsistent = 0;
    };
    const Counts c = tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, nv, kStarVertices), Counts{},
        [&](const tbb::blocked_range<std::size_t>& vs, Counts c) {
          std::vector<std::pair<std::int32_t, std::int32_t>> other;  // (opposite-edge vertex w, local triangle index)
          struct HalfEdge {
            std::uint32_t other;  // the larger vertex
            bool forward;         // traversed from v to it
          };
          std::vector<HalfEdge> he;
          UnionFind fans;
          for (std::size_t v = vs.begin(); v < vs.end(); ++v) {
            const std::uint32_t b = start[v], e = start[v + 1];
            if (b == e) continue;
            ++c.used;
            bool one_fan = false;
            long star_edges = 0;
            if (fast_star(std::uint32_t(v), incident.data() + b, e - b, mesh.triangles, one_fan, star_edges)) {
              c.nonmanifold += !one_fan;
              c.edges += star_edges;
              continue;
            }
            other.clear(), he.clear();
            for (std::uint32_t k = b; k < e; ++k) {
              const auto& t = mesh.triangles[incident[k]];
              for (std::int32_t w : t)
                if (std::size_t(w) != v) other.emplace_back(w, std::int32_t(k - b));
              // A triangle holding v twice is listed twice: its edges once.
              if (k > b && incident[k] == incident[k - 1]) continue;
              for (int i = 0; i < 3; ++i) {
                const auto x = std::uint32_t(t[i]), y = std::uint32_t(t[(i + 1) % 3]);
                if (x != y && std::min(x, y) == v) he.push_back({std::max(x, y), x < y});  // x == y: not an edge
              }
            }
            std::sort(other.begin(), other.end());
            fans.reset(e - b);
            int n_fans = int(e - b);
            for (std::size_t k = 1; k < other.size(); ++k)
              if (other[k].first == other[k - 1].first && fans.unite(other[k].second, other[k - 1].second)) --n_fans;
            if (n_fans > 1) ++c.nonmanifold;
            std::sort(he.begin(), he.end(), [](const HalfEdge& x, const HalfEdge& y) { return x.other < y.other; });
            for (auto s = he.begin(); s != he.end();) {
              auto t = s;
              while (t != he.end() && t->other == s->other) ++t;
              const auto n = t - s;
              ++c.edges;
              if (n == 1) ++c.boundary;
              else if (n > 2) ++c.nonmanifold_edges;
              else if (s->forward == (s + 1)->forward) ++c.inconsistent;
              s = t;
            }
          }
          return c;
        },
        [](Counts a, const Counts& b) {
          return Counts{a.used + b.used,         a.nonmanifold + b.nonmanifold,
                        a.edges + b.edges,       a.boundary + b.boundary,
                        a.nonmanifold_edges + b.nonmanifold_edges, a.inconsistent + b.inconsistent};
        });
    used_vertices = c.used;
    r.nonmanifold_vertices = c.nonmanifold;
    edges = c.edges, r.boundary_edges = c.boundary, r.nonmanifold_edges = c.nonmanifold_edges;
    r.inconsistent_edges = c.inconsistent;
  };
  auto component_pass = [&] {  // components through shared vertices (of the vertices some triangle uses)
    UnionFind comp(nv);
    std::vector<std::uint8_t> used(nv, 0);
    for (const auto& t : mesh.triangles) {
      comp.unite(t[0], t[1]), comp.unite(t[1], t[2]);
      used[std::size_t(t[0])] = used[std::size_t(t[1])] = used[std::size_t(t[2])] = 1;
    }
    for (std::size_t v = 0; v < nv; ++v)
      if (used[v] && comp.find(std::int32_t(v)) == std::int32_t(v)) ++r.components;
  };
  tbb::parallel_invoke(geometry, star_pass, component_pass);

  r.euler = used_vertices - edges + long(nf);
  r.closed = r.boundary_edges == 0;
  r.manifold = r.nonmanifold_edges == 0 && r.nonmanifold_vertices == 0;
  r.oriented = r.inconsistent_edges == 0;
  return r;
}

}  // namespace isoloft
