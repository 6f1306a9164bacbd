#include "isoloft/mesh/plane_cut.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
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

namespace {

double segment_distance(const Vec2d& p, const Vec2d& a, const Vec2d& b) {
  const Vec2d ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (a + t * ab - p).norm();
}

}  // namespace

namespace {

// `loop` at m equal steps of its length (at: length at each vertex), from its first vertex.
std::vector<Vec2d> equal_steps(const std::vector<Vec2d>& loop, const std::vector<double>& at, std::size_t m) {
  const std::size_t n = loop.size();
  const double step = at[n] / double(m);
  std::vector<Vec2d> points;
  points.reserve(m);
  for (std::size_t k = 0, i = 0; k < m; ++k) {
    const double s = double(k) * step;
    while (at[i + 1] < s) ++i;
    const double seg = at[i + 1] - at[i];
    const double t = seg > 0 ? (s - at[i]) / seg : 0.0;
    points.push_back(loop[i] + t * (loop[(i + 1) % n] - loop[i]));
  }
  return points;
}

}  // namespace

ResampledLoop resample_loop(const std::vector<Vec2d>& loop, double spacing) {
  ResampledLoop out;
  const std::size_t n = loop.size();
  if (n < 3 || !(spacing > 0)) {
    out.points = loop;
    return out;
  }
  std::vector<double> at(n + 1, 0.0);  // length along the loop at each vertex (at[n]: back to the first)
  for (std::size_t i = 0; i < n; ++i) at[i + 1] = at[i] + (loop[(i + 1) % n] - loop[i]).norm();
  const double length = at[n];
  if (!(length > 0)) {
    out.points = loop;
    return out;
  }
  // The least count from the spacing's on that keeps the area.
  const double area = std::abs(loop_area(loop));
  const std::size_t most = std::max<std::size_t>(3, kResampleMostPerVertex * n);
  std::size_t m = std::max<std::size_t>(3, std::size_t(std::lround(length / spacing)));
  for (;; ++m) {
    out.points = equal_steps(loop, at, m);
    if (m >= most || std::abs(std::abs(loop_area(out.points)) - area) <= kResampleAreaShare * area) break;
  }
  const double step = length / double(m);
  double sum = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t k = std::min(m - 1, std::size_t(at[i] / step));
    const double d = segment_distance(loop[i], out.points[k], out.points[(k + 1) % m]);
    out.max_deviation = std::max(out.max_deviation, d);
    sum += d;
  }
  out.mean_deviation = sum / double(n);
  return out;
}

double volume_above(const TriMesh& mesh, double z) { return volumes_above(mesh, {z})[0]; }

std::vector<double> volumes_above(const TriMesh& mesh, const std::vector<double>& zs) {
  std::vector<double> six(zs.size(), 0.0);  // six times each volume
  if (mesh.vertices.empty()) return six;
  // A plane below the whole mesh (or at -infinity) is moved up to its lowest
  // vertex: same volume, a finite origin.
  double lowest = std::numeric_limits<double>::infinity();
  for (const Vec3f& v : mesh.vertices) lowest = std::min(lowest, double(v.z()));
  std::vector<double> at(zs.size());
  for (std::size_t k = 0; k < zs.size(); ++k) at[k] = std::max(zs[k], lowest);
  for (const auto& t : mesh.triangles) {
    const Vec3d v[3] = {mesh.vertices[std::size_t(t[0])].cast<double>(), mesh.vertices[std::size_t(t[1])].cast<double>(),
                        mesh.vertices[std::size_t(t[2])].cast<double>()};
    for (std::size_t k = 0; k < zs.size(); ++k) {
      const double z = at[k];
      const Vec3d origin(0, 0, z);
      const int above = int(v[0].z() >= z) + int(v[1].z() >= z) + int(v[2].z() >= z);
      if (above == 0) continue;  // clipped away
      if (above == 3) {          // whole: the one fan triangle of the clip below, the same arithmetic
        six[k] += (v[0] - origin).dot((v[1] - origin).cross(v[2] - origin));
        continue;
      }
      // The triangle clipped to z >= `z` (a polygon of up to 4 corners, in order), fanned.
      Vec3d poly[4];
      int n = 0;
      for (int i = 0; i < 3; ++i) {
        const Vec3d& a = v[i];
        const Vec3d& b = v[(i + 1) % 3];
        if (a.z() >= z) poly[n++] = a;
        if ((a.z() >= z) != (b.z() >= z)) poly[n++] = a + (z - a.z()) / (b.z() - a.z()) * (b - a);
      }
      for (int i = 1; i + 1 < n; ++i) six[k] += (poly[0] - origin).dot((poly[i] - origin).cross(poly[i + 1] - origin));
    }
  }
  for (double& x : six) x /= 6.0;
  return six;
}

double mean_point_spacing(const std::vector<std::vector<Vec2d>>& loops) {
  double length = 0;
  std::size_t points = 0;
  for (const auto& l : loops) {
    for (std::size_t i = 0; i < l.size(); ++i) length += (l[(i + 1) % l.size()] - l[i]).norm();
    points += l.size();
  }
  return points ? length / double(points) : 0.0;
}

double loop_area(const std::vector<Vec2d>& loop) {
  double a = 0;
  for (std::size_t i = 0, j = loop.size() - 1; i < loop.size(); j = i++)
    a += loop[j].x() * loop[i].y() - loop[i].x() * loop[j].y();
  return 0.5 * a;
}

double distance_to_loop(const Vec2d& p, const std::vector<Vec2d>& loop) {
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0, j = loop.size() - 1; i < loop.size(); j = i++)
    best = std::min(best, segment_distance(p, loop[j], loop[i]));
  return best;
}

}  // namespace isoloft
