// @file mesh/slab_join.cpp
// @brief join_slabs(): mesh/slab_join.h.
#include "isoloft/mesh/slab_join.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <map>
#include <utility>

namespace isoloft {

namespace {

using Key = std::array<std::uint32_t, 3>;  // a position's bits: equal floats weld, nothing else

Key key(const Vec3f& v) {
  Key k;
  std::memcpy(k.data(), v.data(), sizeof(k));
  return k;
}

// The vertices on edges of one triangle only (the open cuts), in index order.
std::vector<std::int32_t> boundary_vertices(const TriMesh& m) {
  std::map<std::pair<std::int32_t, std::int32_t>, int> uses;
  for (const auto& t : m.triangles)
    for (int e = 0; e < 3; ++e) ++uses[std::minmax(t[std::size_t(e)], t[std::size_t((e + 1) % 3)])];
  std::vector<std::int32_t> out;
  for (const auto& [edge, n] : uses)
    if (n == 1) out.push_back(edge.first), out.push_back(edge.second);
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

}  // namespace

SlabJoinResult join_slabs(const std::vector<TriMesh>& parts) {
  SlabJoinResult r;
  std::vector<std::vector<std::int32_t>> boundary(parts.size());
  for (std::size_t s = 0; s < parts.size(); ++s) boundary[s] = boundary_vertices(parts[s]);
  // Part s's boundary vertices by position, waiting for part s + 1's.
  std::map<Key, std::vector<std::int32_t>> open;  // part s - 1's unwelded boundary vertices (joined indices) by position
  for (std::size_t s = 0; s < parts.size(); ++s) {
    const TriMesh& p = parts[s];
    std::vector<std::int32_t> index(p.vertices.size(), -1);
    for (const std::int32_t v : boundary[s]) {
      const auto it = open.find(key(p.vertices[std::size_t(v)]));
      if (it == open.end() || it->second.empty()) continue;
      index[std::size_t(v)] = it->second.front();
      it->second.erase(it->second.begin());
      ++r.welded;
    }
    for (const auto& [k, left] : open) r.unmatched += long(left.size());
    std::vector<char> welded(p.vertices.size(), 0);
    for (std::size_t v = 0; v < p.vertices.size(); ++v) {
      welded[v] = index[v] >= 0;
      if (welded[v]) continue;
      index[v] = std::int32_t(r.mesh.vertices.size());
      r.mesh.vertices.push_back(p.vertices[v]);
    }
    open.clear();
    for (const std::int32_t v : boundary[s])
      if (!welded[std::size_t(v)]) open[key(p.vertices[std::size_t(v)])].push_back(index[std::size_t(v)]);
    for (const auto& t : p.triangles)
      r.mesh.triangles.push_back({index[std::size_t(t[0])], index[std::size_t(t[1])], index[std::size_t(t[2])]});
  }
  for (const auto& [k, left] : open) r.unmatched += long(left.size());
  r.check = check_mesh(r.mesh);
  return r;
}

}  // namespace isoloft
