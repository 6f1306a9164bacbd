#include "isoloft/eval/point_mesh.h"

#include <tbb/blocked_range.h>
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
#include <optional>

#include "isoloft/mesh/decimate_bound.h"

namespace isoloft {

namespace {

// Each round of point_mesh_distances searches this many times farther than
// the one before, for the points whose distance was beyond its reach.
constexpr double kReachGrowth = 4.0;
// The first rounds go from the triangles to the points (PointCells): the
// first reach, in mean triangle extents (a contour vertex lies a fraction of
// a pixel off the surface made of it: on the RT set 99.4 % within it), and
// the largest reach such a round takes (its work grows with the triangles
// within reach of each point); farther, the triangle grid's rounds.
constexpr double kPointReachExtents = 0.25, kPointReachMaxExtents = 4.0;
// PointCells' cell side in reaches: a small triangle's box grown by the
// reach meets at most 2 x 2 cells of a plane (2 and 8: slower on BODY).
constexpr double kPointCellReaches = 4.0;
// Consecutive triangles boxed together (a run), and runs per task, of a
// round from the triangles to the points.
constexpr std::size_t kBoxRun = 256, kOfferRuns = 64;
// A triangle's box is grown by this much more than the reach a distance is
// taken as exact within, so that a triangle whose computed distance is
// within the reach is surely offered (the distance and the box, in double
// from the same float corners, round ~1e-15 relative).
constexpr double kReachSlack = 1e-6;
// The triangle grid's rounds: at most this many points left, candidates by
// each point's own box, not its plane.
constexpr std::size_t kFewPoints = 64;
// Triangles per task when the candidates near the points' planes are picked.
constexpr std::size_t kSelectChunk = std::size_t(1) << 16;

// A triangle's bounding box, from its float corners.
struct Box {
  Eigen::Vector3f lo, hi;
};

Box triangle_box(const TriMesh& mesh, std::size_t i) {
  const auto& t = mesh.triangles[i];
  const Eigen::Vector3f &a = mesh.vertices[std::size_t(t[0])], &b = mesh.vertices[std::size_t(t[1])],
                        &c = mesh.vertices[std::size_t(t[2])];
  return {a.cwiseMin(b).cwiseMin(c), a.cwiseMax(b).cwiseMax(c)};
}

// The triangles bucketed on a uniform grid (cells of about twice the mean
// triangle extent; only the occupied ones, by sorted key). A small triangle
// (half its box's largest side within kSmallHalfCells cells: all of a
// Marching Cubes mesh) is in the one cell of its box's centre, a larger one
// in every cell its box meets: one entry per triangle on a fine mesh
// (entering each in every cell its box met held several per triangle).
class TriangleGrid {
 public:
  /// The mesh's triangles `ids`.
  TriangleGrid(const TriMesh& mesh, const std::vector<std::int32_t>& ids) : mesh_(mesh) {
    if (ids.empty()) return;
    struct Bounds {
      Vec3d lo = Vec3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
      double extent = 0, largest = 0;  // sum and largest of the boxes' largest sides
    };
    const Bounds all = tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, ids.size()), Bounds{},
        [&](const tbb::blocked_range<std::size_t>& r, Bounds b) {
          for (std::size_t k = r.begin(); k < r.end(); ++k) {
            const Box t = triangle_box(mesh, std::size_t(ids[k]));
            const Vec3d tlo = t.lo.cast<double>(), thi = t.hi.cast<double>();
            b.lo = b.lo.cwiseMin(tlo), b.hi = b.hi.cwiseMax(thi);
            const double side = (thi - tlo).maxCoeff();
            b.extent += side, b.largest = std::max(b.largest, side);
          }
          return b;
        },
        [](Bounds a, const Bounds& b) {
          a.lo = a.lo.cwiseMin(b.lo), a.hi = a.hi.cwiseMax(b.hi), a.extent += b.extent;
          a.largest = std::max(a.largest, b.largest);
          return a;
        });
    lo_ = all.lo;
    cell_ = std::max(kCellExtents * all.extent / double(ids.size()), 1e-6);
    reach_ = std::min(0.5 * all.largest, kSmallHalfCells * cell_);
    for (int a = 0; a < 3; ++a) n_[a] = std::max(1, int(std::floor((all.hi[a] - all.lo[a]) / cell_)) + 1);
    // Entries per triangle, then each written at its offset: one array, no per-thread parts.
    std::vector<std::size_t> first(ids.size() + 1, 0);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, ids.size()), [&](const tbb::blocked_range<std::size_t>& r) {
      for (std::size_t k = r.begin(); k < r.end(); ++k) {
        const Cells c = cells_of(triangle_box(mesh, std::size_t(ids[k])));
        first[k + 1] = c.small ? 1 : std::size_t(c.hi[0] - c.lo[0] + 1) * std::size_t(c.hi[1] - c.lo[1] + 1) *
                                         std::size_t(c.hi[2] - c.lo[2] + 1);
      }
    });
    std::partial_sum(first.begin(), first.end(), first.begin());
    std::vector<std::pair<std::uint64_t, std::int32_t>> entries(first.back());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, ids.size()), [&](const tbb::blocked_range<std::size_t>& r) {
      for (std::size_t k = r.begin(); k < r.end(); ++k) {
        const Cells c = cells_of(triangle_box(mesh, std::size_t(ids[k])));
        std::size_t e = first[k];
        for (int z = c.lo[2]; z <= c.hi[2]; ++z)
          for (int y = c.lo[1]; y <= c.hi[1]; ++y)
            for (int x = c.lo[0]; x <= c.hi[0]; ++x) entries[e++] = {key(x, y, z), ids[k]};
      }
    });
    first = {};
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
    double best2 = std::numeric_limits<double>::infinity();
    // Rounds over the cells meeting the box of half side clear + reach_
    // around p (those of earlier rounds skipped), `clear` doubling: an unseen
    // small triangle's box centre lies outside that box, so all of it lies
    // farther than `clear` from p; an unseen large one's box misses it.
    std::array<int, 3> seen_lo{1, 1, 1}, seen_hi{0, 0, 0};  // none yet
    for (double clear = kFirstClearCells * cell_;; clear *= 2) {
      const Vec3d half = Vec3d::Constant(clear + reach_);
      const auto lo = cell_of(p - half), hi = cell_of(p + half);
      for (int z = lo[2]; z <= hi[2]; ++z)
        for (int y = lo[1]; y <= hi[1]; ++y) {
          const bool inner = z >= seen_lo[2] && z <= seen_hi[2] && y >= seen_lo[1] && y <= seen_hi[1];
          if (!inner) {
            visit_row(p, y, z, lo[0], hi[0], best2);
            continue;
          }
          visit_row(p, y, z, lo[0], seen_lo[0] - 1, best2);
          visit_row(p, y, z, seen_hi[0] + 1, hi[0], best2);
        }
      seen_lo = lo, seen_hi = hi;
      const bool every = lo == std::array<int, 3>{0, 0, 0} && hi == std::array<int, 3>{n_[0] - 1, n_[1] - 1, n_[2] - 1};
      if (every || best2 <= clear * clear) break;
    }
    return std::sqrt(best2);
  }

 private:
  static constexpr double kCellExtents = 2.0;
  // A triangle whose box's half side is at most this many cells is bucketed by
  // its centre alone; the search then looks that much farther (reach_). 0.5:
  // a Marching Cubes triangle spans at most one voxel, under a cell of twice
  // the mean extent.
  static constexpr double kSmallHalfCells = 0.5;
  // The first round's clearance, in cells: a contour vertex lies on or near
  // the surface made of it (a fraction of a pixel), so one round of at most
  // 2 x 2 x 2 cells (half side 0.25 + <= 0.5 cells) finds most.
  static constexpr double kFirstClearCells = 0.25;

  // Cells x0..x1 of row (y, z): the triangles of those occupied, against best2.
  void visit_row(const Vec3d& p, int y, int z, int x0, int x1, double& best2) const {
    if (x0 > x1) return;
    const std::uint64_t last = key(x1, y, z);
    for (auto it = std::lower_bound(keys_.begin(), keys_.end(), key(x0, y, z)); it != keys_.end() && *it <= last; ++it) {
      const std::size_t k = std::size_t(it - keys_.begin());
      for (std::uint32_t q = start_[k]; q < start_[k + 1]; ++q) {
        const auto& t = mesh_.triangles[std::size_t(ids_[q])];
        best2 = std::min(best2, detail::PreparedTriangle(vertex(t[0]), vertex(t[1]), vertex(t[2])).distance_sq(p));
      }
    }
  }

  // The cells a triangle is entered in: its centre's (small), or those its box meets.
  struct Cells {
    std::array<int, 3> lo, hi;
    bool small;
  };
  [[nodiscard]] Cells cells_of(const Box& b) const {
    const Vec3d lo = b.lo.cast<double>(), hi = b.hi.cast<double>();
    if (0.5 * (hi - lo).maxCoeff() <= kSmallHalfCells * cell_) {
      const auto c = cell_of(0.5 * (lo + hi));
      return {c, c, true};
    }
    return {cell_of(lo), cell_of(hi), false};
  }
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
  double reach_ = 0;  // the largest half side of a small triangle's box
  std::array<int, 3> n_{1, 1, 1};
  std::vector<std::uint64_t> keys_;   // occupied cells, increasing
  std::vector<std::uint32_t> start_;  // cell keys_[k] holds ids_[start_[k] .. start_[k + 1])
  std::vector<std::int32_t> ids_;
};

// The points still to do by plane (their distinct z), row (y) and column
// (x) of cells of side `cell`: for each plane's rows its occupied cells, in
// x order. One pass over the triangles offers each triangle near a plane to
// the points in the cells its box, grown by the reach, meets (a large
// triangle: to its planes' points, if fewer than those rows): a triangle
// within the reach of a point is among those offered to it, so a distance
// <= reach is exact, the least of the same distances as the triangle grid's
// search.
class PointCells {
 public:
  /// A thread's part: the least squared distance found for each point
  /// (best2[k] for todo[k]) and the candidates of the triangle at hand.
  struct Part {
    std::vector<double> best2;
    std::vector<std::uint32_t> near;
  };

  PointCells(const std::vector<Vec3d>& points, const std::vector<std::size_t>& todo, std::vector<double> zs, double reach)
      : reach_(reach * (1 + kReachSlack)), cell_(kPointCellReaches * reach), zs_(std::move(zs)) {
    Vec2d hi = Vec2d::Constant(-std::numeric_limits<double>::infinity());
    lo_ = -hi;
    for (const std::size_t i : todo) lo_ = lo_.cwiseMin(points[i].head<2>()), hi = hi.cwiseMax(points[i].head<2>());
    // At most kMaxCells columns (the key packs (plane, row, column) in 64
    // bits), and rows, all planes', at most kRowsPerPoint per point.
    cell_ = std::max({cell_, (hi - lo_).maxCoeff() / double(kMaxCells - 1),
                      (hi.y() - lo_.y()) * double(zs_.size()) / (kRowsPerPoint * double(todo.size()))});
    for (int a = 0; a < 2; ++a) n_[a] = int(std::floor((hi[a] - lo_[a]) / cell_)) + 1;
    std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(todo.size());
    for (std::size_t k = 0; k < todo.size(); ++k) {
      const Vec3d& p = points[todo[k]];
      const auto plane = std::uint64_t(std::lower_bound(zs_.begin(), zs_.end(), p.z()) - zs_.begin());
      keyed[k] = {(plane << 42) | (std::uint64_t(cell_of(p.y(), 1)) << 21) | std::uint64_t(cell_of(p.x(), 0)),
                  std::uint32_t(k)};
    }
    std::sort(keyed.begin(), keyed.end());
    row_start_.assign(zs_.size() * std::size_t(n_[1]) + 1, 0);
    for (std::size_t k = 0; k < keyed.size(); ++k) {
      index_.push_back(keyed[k].second);
      at_.push_back(points[todo[keyed[k].second]]);
      if (k > 0 && keyed[k].first == keyed[k - 1].first) continue;
      const std::uint64_t row = keyed[k].first >> 21;
      ++row_start_[std::size_t(row >> 21) * std::size_t(n_[1]) + std::size_t(row & (kMaxCells - 1)) + 1];
      column_.push_back(std::int32_t(keyed[k].first & (kMaxCells - 1)));
      cell_start_.push_back(std::uint32_t(k));
    }
    cell_start_.push_back(std::uint32_t(keyed.size()));
    std::partial_sum(row_start_.begin(), row_start_.end(), row_start_.begin());
  }

  /// Whether box `b` grown by the reach meets a plane within the points' box.
  [[nodiscard]] bool near(const Box& b) const {
    const Vec3d lo = b.lo.cast<double>() - Vec3d::Constant(reach_), hi = b.hi.cast<double>() + Vec3d::Constant(reach_);
    const auto plane = std::lower_bound(zs_.begin(), zs_.end(), lo.z());
    return plane != zs_.end() && *plane <= hi.z() && hi.x() >= lo_.x() && hi.y() >= lo_.y() &&
           cell_of(lo.x(), 0) < n_[0] && cell_of(lo.y(), 1) < n_[1];
  }

  /// Offers triangle `i` to the points near it.
  void offer(const TriMesh& mesh, std::size_t i, Part& part) const {
    const Box b = triangle_box(mesh, i);
    const Vec3d lo = b.lo.cast<double>() - Vec3d::Constant(reach_), hi = b.hi.cast<double>() + Vec3d::Constant(reach_);
    const auto p0 = std::size_t(std::lower_bound(zs_.begin(), zs_.end(), lo.z()) - zs_.begin());
    if (p0 == zs_.size() || zs_[p0] > hi.z() || hi.x() < lo_.x() || hi.y() < lo_.y()) return;
    const int x0 = cell_of(lo.x(), 0), y0 = cell_of(lo.y(), 1);
    if (x0 >= n_[0] || y0 >= n_[1]) return;
    const int x1 = std::min(cell_of(hi.x(), 0), n_[0] - 1), y1 = std::min(cell_of(hi.y(), 1), n_[1] - 1);
    const auto p1 = std::size_t(std::upper_bound(zs_.begin() + std::ptrdiff_t(p0), zs_.end(), hi.z()) - zs_.begin());
    part.near.clear();
    const auto visit = [&](std::uint32_t begin, std::uint32_t end) {
      for (std::uint32_t q = begin; q < end; ++q)
        if (((at_[q].array() >= lo.array()) && (at_[q].array() <= hi.array())).all()) part.near.push_back(q);
    };
    const std::size_t rows = (p1 - p0) * std::size_t(y1 - y0 + 1);
    const std::uint32_t first = cell_start_[row_start_[p0 * std::size_t(n_[1])]],
                        last = cell_start_[row_start_[p1 * std::size_t(n_[1])]];
    if (rows > last - first) {
      visit(first, last);
    } else {
      for (std::size_t plane = p0; plane < p1; ++plane)
        for (int y = y0; y <= y1; ++y) {
          const std::size_t row = plane * std::size_t(n_[1]) + std::size_t(y);
          const auto end = column_.begin() + std::ptrdiff_t(row_start_[row + 1]);
          for (auto c = std::lower_bound(column_.begin() + std::ptrdiff_t(row_start_[row]), end, x0); c != end && *c <= x1;
               ++c) {
            const auto cell = std::size_t(c - column_.begin());
            visit(cell_start_[cell], cell_start_[cell + 1]);
          }
        }
    }
    if (part.near.empty()) return;
    const auto& t = mesh.triangles[i];
    const detail::PreparedTriangle tri(vertex(mesh, t[0]), vertex(mesh, t[1]), vertex(mesh, t[2]));
    for (const std::uint32_t q : part.near) {
      double& best = part.best2[index_[q]];
      best = std::min(best, tri.distance_sq(at_[q]));
    }
  }

 private:
  static constexpr int kMaxCells = 1 << 21;
  // Rows of cells (all planes') per point at most: bounds the row table
  // where the points lie on many planes.
  static constexpr double kRowsPerPoint = 8.0;

  static Vec3d vertex(const TriMesh& mesh, std::int32_t v) { return mesh.vertices[std::size_t(v)].cast<double>(); }
  // Cell along axis a of a coordinate: 0 below the points' low corner; the caller bounds it above.
  [[nodiscard]] int cell_of(double x, int a) const {
    return int(std::clamp(std::floor((x - lo_[a]) / cell_), 0.0, double(kMaxCells)));
  }

  double reach_, cell_;
  std::vector<double> zs_;
  Vec2d lo_;
  std::array<int, 2> n_{1, 1};
  std::vector<std::uint32_t> row_start_;   // row (plane, y)'s cells: column_[row_start_[r] .. row_start_[r + 1])
  std::vector<std::int32_t> column_;       // each occupied cell's x, by row then x
  std::vector<std::uint32_t> cell_start_;  // cell c's points: at_[cell_start_[c] .. cell_start_[c + 1])
  std::vector<std::uint32_t> index_;       // by cell: the point's index in todo
  std::vector<Vec3d> at_;                  // by cell: the point
};

}  // namespace

std::vector<double> point_mesh_distances(const TriMesh& mesh, const std::vector<Vec3d>& points) {
  std::vector<double> d(points.size(), std::numeric_limits<double>::infinity());
  if (mesh.triangles.empty() || points.empty()) return d;
  // Rounds, each exact for the points within its reach of the mesh, the
  // others going on with kReachGrowth times the reach: first from the
  // triangles to the points (PointCells), each triangle offered to the
  // points near it; then over a grid of the triangles within the reach of
  // the z of a point still to do (of the point itself when few are left),
  // until the round that holds every triangle. A contour vertex lies on or
  // near the surface made of it, so nearly all are done in the first round.
  // The triangles' boxes are made from their corners where needed, not held;
  // those of runs of kBoxRun consecutive triangles (a Marching Cubes mesh's
  // are near each other) are, so a round from the triangles skips the runs
  // far from every point. The extents summed in order.
  const std::size_t runs = (mesh.triangles.size() + kBoxRun - 1) / kBoxRun;
  std::vector<Box> run_box(runs);
  std::vector<double> run_extent(runs, 0.0);
  tbb::parallel_for(std::size_t(0), runs, [&](std::size_t r) {
    const std::size_t end = std::min(mesh.triangles.size(), (r + 1) * kBoxRun);
    Box& all = run_box[r];
    all = triangle_box(mesh, r * kBoxRun);
    for (std::size_t i = r * kBoxRun; i < end; ++i) {
      const Box b = triangle_box(mesh, i);
      all.lo = all.lo.cwiseMin(b.lo), all.hi = all.hi.cwiseMax(b.hi);
      run_extent[r] += double((b.hi - b.lo).maxCoeff());
    }
  });
  const double extent = std::accumulate(run_extent.begin(), run_extent.end(), 0.0);
  const double mean_extent = extent / double(mesh.triangles.size());
  double reach = kPointReachExtents * mean_extent;
  std::vector<std::size_t> todo(points.size());
  std::iota(todo.begin(), todo.end(), std::size_t(0));
  for (; !todo.empty() && reach > 0 && reach <= kPointReachMaxExtents * mean_extent; reach *= kReachGrowth) {
    std::vector<double> zs;
    for (const std::size_t i : todo) zs.push_back(points[i].z());
    std::sort(zs.begin(), zs.end());
    zs.erase(std::unique(zs.begin(), zs.end()), zs.end());
    if (zs.size() >= std::size_t(1) << 22) break;  // not planes (a key holds 22 bits of plane): the triangle grid's rounds
    const PointCells cells(points, todo, std::move(zs), reach);
    tbb::enumerable_thread_specific<PointCells::Part> parts(
        PointCells::Part{std::vector<double>(todo.size(), std::numeric_limits<double>::infinity()), {}});
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, runs, kOfferRuns), [&](const tbb::blocked_range<std::size_t>& rs) {
      PointCells::Part& b = parts.local();
      for (std::size_t r = rs.begin(); r < rs.end(); ++r)
        if (cells.near(run_box[r]))
          for (std::size_t i = r * kBoxRun; i < std::min(mesh.triangles.size(), (r + 1) * kBoxRun); ++i) cells.offer(mesh, i, b);
    });
    // The least over the threads' parts: the same whichever thread offered what.
    for (std::size_t k = 0; k < todo.size(); ++k) {
      double b = std::numeric_limits<double>::infinity();
      for (const auto& part : parts) b = std::min(b, part.best2[k]);
      d[todo[k]] = std::sqrt(b);
    }
    std::erase_if(todo, [&](std::size_t i) { return d[i] <= reach; });
  }
  while (!todo.empty()) {
    std::vector<std::int32_t> ids;
    if (todo.size() <= kFewPoints) {
      // A few points left (e.g. contour specks the grid dropped): the
      // triangles whose box comes within reach of one of them.
      for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
        const Box b = triangle_box(mesh, i);
        const Vec3d lo = b.lo.cast<double>(), hi = b.hi.cast<double>();
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
      // Chunks side by side, joined in order: the ids increasing, as one pass gives them.
      const std::size_t chunks = (mesh.triangles.size() + kSelectChunk - 1) / kSelectChunk;
      std::vector<std::vector<std::int32_t>> part(chunks);
      tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t c) {
        for (std::size_t i = c * kSelectChunk; i < std::min(mesh.triangles.size(), (c + 1) * kSelectChunk); ++i) {
          const Box b = triangle_box(mesh, i);
          const auto it = std::lower_bound(zs.begin(), zs.end(), double(b.lo.z()) - reach);
          if (it != zs.end() && *it <= double(b.hi.z()) + reach) part[c].push_back(std::int32_t(i));
        }
      });
      for (const auto& p : part) ids.insert(ids.end(), p.begin(), p.end());
    }
    const bool every = ids.size() == mesh.triangles.size();
    const TriangleGrid grid(mesh, ids);
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
