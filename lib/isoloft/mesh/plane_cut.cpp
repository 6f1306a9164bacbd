#include "isoloft/mesh/plane_cut.h"

#include <cstdint>
#include <unordered_map>
#include <utility>

namespace isoloft {

std::vector<std::vector<Vec2d>> cut_mesh(const TriMesh& mesh, double z) {
  // An edge crossing the plane is keyed by its (below, above) vertex pair;
  // each crossing triangle links the crossing point of one edge to the next
  // one's, walking with the outside on the right seen from +z.
  auto key = [](std::int32_t a, std::int32_t b) { return (std::uint64_t(std::uint32_t(a)) << 32) | std::uint32_t(b); };
  auto above = [&](std::int32_t v) { return double(mesh.vertices[std::size_t(v)].z()) >= z; };
  std::unordered_map<std::uint64_t, std::uint64_t> next;  // crossing edge -> the following crossing edge
  for (const auto& t : mesh.triangles) {
    const bool up[3] = {above(t[0]), above(t[1]), above(t[2])};
    if (up[0] == up[1] && up[1] == up[2]) continue;
    // Counter-clockwise seen from outside: the cut runs counter-clockwise
    // around the inside (seen from +z) from the edge going down (above ->
    // below) to the edge going up (below -> above).
    std::uint64_t down = 0, rise = 0;
    for (int i = 0; i < 3; ++i) {
      const std::int32_t a = t[i], b = t[(i + 1) % 3];
      if (!up[i] && up[(i + 1) % 3]) rise = key(a, b);
      if (up[i] && !up[(i + 1) % 3]) down = key(b, a);
    }
    next[down] = rise;
  }
  auto point = [&](std::uint64_t k) {
    const Vec3f& a = mesh.vertices[k >> 32];
    const Vec3f& b = mesh.vertices[k & 0xffffffffu];
    const double za = a.z(), zb = b.z();
    const double t = zb > za ? (z - za) / (zb - za) : 0.0;
    return Vec2d(a.x() + t * (double(b.x()) - a.x()), a.y() + t * (double(b.y()) - a.y()));
  };
  std::vector<std::vector<Vec2d>> loops;
  while (!next.empty()) {
    const std::uint64_t start = next.begin()->first;
    std::vector<Vec2d> loop;
    std::uint64_t k = start;
    bool closed = false;
    while (true) {
      const auto it = next.find(k);
      if (it == next.end()) break;  // an open chain (a mesh with a boundary)
      const std::uint64_t following = it->second;
      next.erase(it);
      const Vec2d p = point(k);
      if (loop.empty() || p != loop.back()) loop.push_back(p);
      k = following;
      if (k == start) {
        closed = true;
        break;
      }
    }
    while (loop.size() > 1 && loop.front() == loop.back()) loop.pop_back();
    if (closed && loop.size() >= 3) loops.push_back(std::move(loop));
  }
  return loops;
}

}  // namespace isoloft
