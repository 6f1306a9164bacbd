#include "isoloft/eval/point_mesh.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <numeric>

#include "isoloft/mesh/decimate_bound.h"

namespace isoloft {

namespace {

// Triangles within this many mean triangle extents of a point's plane are
// searched first, then this many times farther each round (point_mesh_distances).
constexpr double kPlaneReachExtents = 2.0, kReachGrowth = 4.0;
// At most this many points left: candidates by each point's own box, not its plane.
constexpr std::size_t kFewPoints = 64;

// A triangle's bounding box.
struct Box {
  Eigen::Vector3f lo, hi;
};

// The triangles bucketed by the cells their boxes meet (cells of about twice
// the mean triangle extent; only the occupied ones, by sorted key).
class TriangleGrid {
 public:
  /// The mesh's triangles `ids`; boxes[i] is triangle i's box.
  TriangleGrid(const TriMesh& mesh, const std::vector<Box>& boxes, const std::vector<std::int32_t>& ids) : mesh_(mesh) {
    if (ids.empty()) return;
    struct Bounds {
      Vec3d lo = Vec3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
      double extent = 0;
    };
    const Bounds all = tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, ids.size()), Bounds{},
        [&](const tbb::blocked_range<std::size_t>& r, Bounds b) {
          for (std::size_t k = r.begin(); k < r.end(); ++k) {
            const Box& t = boxes[std::size_t(ids[k])];
            const Vec3d tlo = t.lo.cast<double>(), thi = t.hi.cast<double>();
            b.lo = b.lo.cwiseMin(tlo), b.hi = b.hi.cwiseMax(thi);
            b.extent += (thi - tlo).maxCoeff();
          }
          return b;
        },
        [](Bounds a, const Bounds& b) {
          a.lo = a.lo.cwiseMin(b.lo), a.hi = a.hi.cwiseMax(b.hi), a.extent += b.extent;
          return a;
        });
    lo_ = all.lo;
    cell_ = std::max(kCellExtents * all.extent / double(ids.size()), 1e-6);
    for (int a = 0; a < 3; ++a) n_[a] = std::max(1, int(std::floor((all.hi[a] - all.lo[a]) / cell_)) + 1);
    // Each triangle in every cell its box meets; the sort below orders them.
    using Entries = std::vector<std::pair<std::uint64_t, std::int32_t>>;
    tbb::enumerable_thread_specific<Entries> parts;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, ids.size()), [&](const tbb::blocked_range<std::size_t>& r) {
      Entries& out = parts.local();
      for (std::size_t k = r.begin(); k < r.end(); ++k) {
        const Box& t = boxes[std::size_t(ids[k])];
        const auto c0 = cell_of(t.lo.cast<double>()), c1 = cell_of(t.hi.cast<double>());
        for (int z = c0[2]; z <= c1[2]; ++z)
          for (int y = c0[1]; y <= c1[1]; ++y)
            for (int x = c0[0]; x <= c1[0]; ++x) out.emplace_back(key(x, y, z), ids[k]);
      }
    });
    Entries entries;
    for (const Entries& e : parts) entries.insert(entries.end(), e.begin(), e.end());
    tbb::parallel_sort(entries.begin(), entries.end());
    ids_.reserve(entries.size());
    for (std::size_t e = 0; e < entries.size(); ++e) {
      if (e == 0 || entries[e].first != entries[e - 1].first) keys_.push_back(entries[e].first), start_.push_back(std::uint32_t(e));
      ids_.push_back(entries[e].second);
    }
    start_.push_back(std::uint32_t(entries.size()));
  }

  [[nodiscard]] double distance(const Vec3d& p) const {
    if (keys_.empty()) return std::numeric_limits<double>::infinity();
    const auto c = cell_of(p);
    double best2 = std::numeric_limits<double>::infinity();
    // Shells of cells at Chebyshev index distance r: a triangle not in them
    // lies farther than r cells from p.
    for (int r = 0; r <= n_[0] + n_[1] + n_[2]; ++r) {
      for (int z = std::max(0, c[2] - r); z <= std::min(n_[2] - 1, c[2] + r); ++z)
        for (int y = std::max(0, c[1] - r); y <= std::min(n_[1] - 1, c[1] + r); ++y)
          for (int x = std::max(0, c[0] - r); x <= std::min(n_[0] - 1, c[0] + r); ++x) {
            if (std::max({std::abs(x - c[0]), std::abs(y - c[1]), std::abs(z - c[2])}) != r) continue;
            const auto it = std::lower_bound(keys_.begin(), keys_.end(), key(x, y, z));
            if (it == keys_.end() || *it != key(x, y, z)) continue;
            const std::size_t k = std::size_t(it - keys_.begin());
            for (std::uint32_t q = start_[k]; q < start_[k + 1]; ++q) {
              const auto& t = mesh_.triangles[std::size_t(ids_[q])];
              best2 = std::min(best2, detail::PreparedTriangle(vertex(t[0]), vertex(t[1]), vertex(t[2])).distance_sq(p));
            }
          }
      // Every unseen triangle lies outside the block of cells within r of c:
      // at least as far as p is from that block's nearest face.
      double reach = std::numeric_limits<double>::infinity();
      for (int a = 0; a < 3; ++a) {
        if (c[a] - r > 0) reach = std::min(reach, p[a] - (lo_[a] + double(c[a] - r) * cell_));
        if (c[a] + r < n_[a] - 1) reach = std::min(reach, lo_[a] + double(c[a] + r + 1) * cell_ - p[a]);
      }
      if (best2 <= reach * reach || std::isinf(reach)) break;
    }
    return std::sqrt(best2);
  }

 private:
  static constexpr double kCellExtents = 2.0;

  [[nodiscard]] Vec3d vertex(std::int32_t v) const { return mesh_.vertices[std::size_t(v)].cast<double>(); }
  [[nodiscard]] std::array<int, 3> cell_of(const Vec3d& p) const {
    std::array<int, 3> c{};
    for (int a = 0; a < 3; ++a) c[a] = std::clamp(int(std::floor((p[a] - lo_[a]) / cell_)), 0, n_[a] - 1);
    return c;
  }
  [[nodiscard]] std::uint64_t key(int x, int y, int z) const {
    return (std::uint64_t(z) * std::uint64_t(n_[1]) + std::uint64_t(y)) * std::uint64_t(n_[0]) + std::uint64_t(x);
  }

  const TriMesh& mesh_;
  Vec3d lo_ = Vec3d::Zero();
  double cell_ = 1;
  std::array<int, 3> n_{1, 1, 1};
  std::vector<std::uint64_t> keys_;   // occupied cells, increasing
  std::vector<std::uint32_t> start_;  // cell keys_[k] holds ids_[start_[k] .. start_[k + 1])
  std::vector<std::int32_t> ids_;
};

}  // namespace

std::vector<double> point_mesh_distances(const TriMesh& mesh, const std::vector<Vec3d>& points) {
  std::vector<double> d(points.size(), std::numeric_limits<double>::infinity());
  if (mesh.triangles.empty() || points.empty()) return d;
  // Contour vertices lie on a few planes: each round searches only the
  // triangles within `reach` of the z of a point still to do (of the point
  // itself when few are left); a triangle nearer than reach to a point is
  // among them, so a distance <= reach is exact. The others go on with
  // kReachGrowth times the reach, until the round that holds every triangle.
  std::vector<Box> boxes(mesh.triangles.size());
  const double extent = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, mesh.triangles.size()), 0.0,
      [&](const tbb::blocked_range<std::size_t>& r, double sum) {
        for (std::size_t i = r.begin(); i < r.end(); ++i) {
          const auto& t = mesh.triangles[i];
          const Eigen::Vector3f &a = mesh.vertices[std::size_t(t[0])], &b = mesh.vertices[std::size_t(t[1])],
                                &c = mesh.vertices[std::size_t(t[2])];
          boxes[i] = {a.cwiseMin(b).cwiseMin(c), a.cwiseMax(b).cwiseMax(c)};
          sum += double((boxes[i].hi - boxes[i].lo).maxCoeff());
        }
        return sum;
      },
      std::plus<double>());
  double reach = kPlaneReachExtents * extent / double(mesh.triangles.size());
  std::vector<std::size_t> todo(points.size());
  std::iota(todo.begin(), todo.end(), std::size_t(0));
  while (!todo.empty()) {
    std::vector<std::int32_t> ids;
    if (todo.size() <= kFewPoints) {
      // A few points left (e.g. contour specks the grid dropped): the
      // triangles whose box comes within reach of one of them.
      for (std::size_t i = 0; i < boxes.size(); ++i) {
        const Vec3d lo = boxes[i].lo.cast<double>(), hi = boxes[i].hi.cast<double>();
        for (const std::size_t k : todo)
          if (((points[k].array() >= lo.array() - reach) && (points[k].array() <= hi.array() + reach)).all()) {
            ids.push_back(std::int32_t(i));
            break;
          }
      }
    } else {
      std::vector<double> zs;
      for (const std::size_t i : todo) zs.push_back(points[i].z());
      std::sort(zs.begin(), zs.end());
      zs.erase(std::unique(zs.begin(), zs.end()), zs.end());
      for (std::size_t i = 0; i < boxes.size(); ++i) {
        const auto it = std::lower_bound(zs.begin(), zs.end(), double(boxes[i].lo.z()) - reach);
        if (it != zs.end() && *it <= double(boxes[i].hi.z()) + reach) ids.push_back(std::int32_t(i));
      }
    }
    const bool every = ids.size() == mesh.triangles.size();
    const TriangleGrid grid(mesh, boxes, ids);
    tbb::parallel_for(std::size_t(0), todo.size(), [&](std::size_t k) { d[todo[k]] = grid.distance(points[todo[k]]); });
    if (every) break;
    std::erase_if(todo, [&](std::size_t i) { return d[i] <= reach; });
    reach *= kReachGrowth;
  }
  return d;
}

DistanceSummary summarize_distances(std::vector<double> d) {
  DistanceSummary s;
  s.count = long(d.size());
  if (d.empty()) return s;
  double sum = 0;
  for (const double x : d) sum += x, s.max = std::max(s.max, x);
  s.mean = sum / double(d.size());
  // Nearest rank: the smallest value with at least 95 % of the values at or below it.
  const std::size_t k = std::size_t(std::ceil(0.95 * double(d.size()))) - 1;
  std::nth_element(d.begin(), d.begin() + std::ptrdiff_t(k), d.end());
  s.p95 = d[k];
  return s;
}

nlohmann::json DistanceSummary::to_json(double scale) const {
  return {{"count", count}, {"mean", mean * scale}, {"p95", p95 * scale}, {"max", max * scale}};
}

}  // namespace isoloft
