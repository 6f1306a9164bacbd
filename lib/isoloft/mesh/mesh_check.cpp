#include "isoloft/mesh/mesh_check.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_reduce.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cstdint>
#include <numeric>
#include <string>
#include <vector>

#include "isoloft/core/error.h"

namespace isoloft {

namespace {

// Vertices per task of the star pass: ~1 ms of work each.
constexpr std::size_t kStarVertices = 16384;

struct UnionFind {
  std::vector<std::int32_t> parent;
  explicit UnionFind(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0); }
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

  // Four independent passes side by side, each in its own (serial) order,
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
  auto edge_pass = [&] {
    // The directed half-edges grouped by their undirected key (min, max):
    // bucketed by min vertex (a counting sort), each bucket sorted by max.
    struct HalfEdge {
      std::uint32_t other;  // the larger vertex
      bool forward;         // traversed from min to max
    };
    std::vector<std::uint32_t> first(nv + 1, 0);
    for (std::size_t f = 0; f < nf; ++f)
      for (int k = 0; k < 3; ++k) {
        const auto a = std::uint32_t(mesh.triangles[f][k]), b = std::uint32_t(mesh.triangles[f][(k + 1) % 3]);
        if (a != b) ++first[std::min(a, b) + 1];  // degenerate: not an edge
      }
    std::partial_sum(first.begin(), first.end(), first.begin());
    std::vector<HalfEdge> he(first.back());
    {
      std::vector<std::uint32_t> at(first.begin(), first.end() - 1);
      for (std::size_t f = 0; f < nf; ++f)
        for (int k = 0; k < 3; ++k) {
          const auto a = std::uint32_t(mesh.triangles[f][k]), b = std::uint32_t(mesh.triangles[f][(k + 1) % 3]);
          if (a != b) he[at[std::min(a, b)]++] = {std::max(a, b), a < b};
        }
    }
    for (std::size_t v = 0; v < nv; ++v) {
      const auto b = he.begin() + std::ptrdiff_t(first[v]), e = he.begin() + std::ptrdiff_t(first[v + 1]);
      std::sort(b, e, [](const HalfEdge& x, const HalfEdge& y) { return x.other < y.other; });
      for (auto s = b; s != e;) {
        auto t = s;
        while (t != e && t->other == s->other) ++t;
        const auto n = t - s;
        ++edges;
        if (n == 1) ++r.boundary_edges;
        else if (n > 2) ++r.nonmanifold_edges;
        else if (s->forward == (s + 1)->forward) ++r.inconsistent_edges;
        s = t;
      }
    }
  };
  auto star_pass = [&] {
    // Vertex stars: the triangles around v, joined when they share an edge
    // (v, w), must form a single fan. Incidence lists in CSR form.
    std::vector<std::uint32_t> start(nv + 1, 0);
    for (const auto& t : mesh.triangles)
      for (std::int32_t v : t) ++start[std::size_t(v) + 1];
    std::partial_sum(start.begin(), start.end(), start.begin());
    std::vector<std::uint32_t> incident(start.back()), fill(start.begin(), start.end() - 1);
    for (std::size_t f = 0; f < nf; ++f)
      for (std::int32_t v : mesh.triangles[f]) incident[fill[std::size_t(v)]++] = std::uint32_t(f);
    // Vertex blocks side by side (the longest pass): the counts are sums.
    struct Counts {
      long used = 0, nonmanifold = 0;
    };
    const Counts c = tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, nv, kStarVertices), Counts{},
        [&](const tbb::blocked_range<std::size_t>& vs, Counts c) {
          std::vector<std::pair<std::int32_t, std::int32_t>> other;  // (opposite-edge vertex w, local triangle index)
          for (std::size_t v = vs.begin(); v < vs.end(); ++v) {
            const std::uint32_t b = start[v], e = start[v + 1];
            if (b == e) continue;
            ++c.used;
            other.clear();
            for (std::uint32_t k = b; k < e; ++k)
              for (std::int32_t w : mesh.triangles[incident[k]])
                if (std::size_t(w) != v) other.emplace_back(w, std::int32_t(k - b));
            std::sort(other.begin(), other.end());
            UnionFind fans(e - b);
            int n_fans = int(e - b);
            for (std::size_t k = 1; k < other.size(); ++k)
              if (other[k].first == other[k - 1].first && fans.unite(other[k].second, other[k - 1].second)) --n_fans;
            if (n_fans > 1) ++c.nonmanifold;
          }
          return c;
        },
        [](Counts a, const Counts& b) { return Counts{a.used + b.used, a.nonmanifold + b.nonmanifold}; });
    used_vertices = c.used;
    r.nonmanifold_vertices = c.nonmanifold;
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
  tbb::parallel_invoke(geometry, edge_pass, star_pass, component_pass);

  r.euler = used_vertices - edges + long(nf);
  r.closed = r.boundary_edges == 0;
  r.manifold = r.nonmanifold_edges == 0 && r.nonmanifold_vertices == 0;
  r.oriented = r.inconsistent_edges == 0;
  return r;
}

}  // namespace isoloft
