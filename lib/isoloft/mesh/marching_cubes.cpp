#include "isoloft/mesh/marching_cubes.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include "isoloft/core/error.h"

namespace isoloft {

namespace detail {
namespace {

using Tri = std::array<std::int8_t, 3>;

// Faces of the unit cube: corners in cyclic order, and the outward normal.
constexpr std::array<std::array<int, 4>, 6> kFaceCorners{{{0, 2, 6, 4}, {1, 3, 7, 5}, {0, 1, 5, 4},  //
                                                          {2, 3, 7, 6}, {0, 1, 3, 2}, {4, 5, 7, 6}}};
constexpr std::array<std::array<int, 3>, 6> kFaceNormals{{{-1, 0, 0}, {1, 0, 0}, {0, -1, 0},  //
                                                          {0, 1, 0}, {0, 0, -1}, {0, 0, 1}}};

Vec3d corner_position(int c) { return {double(c & 1), double((c >> 1) & 1), double((c >> 2) & 1)}; }

int edge_between(int a, int b) {
  if (a > b) std::swap(a, b);
  for (int e = 0; e < 12; ++e)
    if (kCubeEdgeCorners[e][0] == a && kCubeEdgeCorners[e][1] == b) return e;
  throw std::logic_error("marching cubes: corners are not joined by a cube edge");
}

Vec3d edge_midpoint(int e) {
  return 0.5 * (corner_position(kCubeEdgeCorners[e][0]) + corner_position(kCubeEdgeCorners[e][1]));
}

struct CaseTable {
  std::array<std::vector<Tri>, 256> triangles;
};

// Minimum-total-diagonal-length triangulation of one loop (vertices = cube
// edge ids, in loop order) avoiding diagonals between two vertices on a common
// cube face. Triangles keep the loop's orientation (indices increase along the
// loop inside each triangle).
std::vector<Tri> triangulate_loop(const std::vector<int>& loop, const std::array<std::array<bool, 12>, 12>& share_face) {
  const int m = int(loop.size());
  constexpr double kInf = std::numeric_limits<double>::infinity();
  auto weight = [&](int i, int j) {  // i < j
    if (j == i + 1 || (i == 0 && j == m - 1)) return 0.0;  // loop edge
    if (share_face[loop[i]][loop[j]]) return kInf;
    return (edge_midpoint(loop[i]) - edge_midpoint(loop[j])).norm();
  };
  std::vector<double> best(std::size_t(m * m), 0.0);
  std::vector<int> split(std::size_t(m * m), -1);
  for (int len = 2; len < m; ++len) {
    for (int i = 0; i + len < m; ++i) {
      const int j = i + len;
      double b = kInf;
      int s = -1;
      for (int k = i + 1; k < j; ++k) {
        const double c = best[i * m + k] + best[k * m + j] + weight(i, k) + weight(k, j);
        if (c < b) b = c, s = k;
      }
      best[i * m + j] = b;
      split[i * m + j] = s;
    }
  }
  if (!(best[m - 1] < kInf)) throw std::logic_error("marching cubes: a loop has no admissible triangulation");
  std::vector<Tri> out;
  std::vector<std::pair<int, int>> todo{{0, m - 1}};
  while (!todo.empty()) {
    auto [i, j] = todo.back();
    todo.pop_back();
    if (j - i < 2) continue;
    const int k = split[i * m + j];
    out.push_back({std::int8_t(loop[i]), std::int8_t(loop[k]), std::int8_t(loop[j])});
    todo.emplace_back(i, k);
    todo.emplace_back(k, j);
  }
  return out;
}

CaseTable build_case_table() {
  std::array<std::array<bool, 12>, 12> share_face{};
  for (const auto& face : kFaceCorners)
    for (int s = 0; s < 4; ++s)
      for (int r = 0; r < 4; ++r)
        share_face[edge_between(face[s], face[(s + 1) % 4])][edge_between(face[r], face[(r + 1) % 4])] = true;

  CaseTable table;
  for (int mask = 0; mask < 256; ++mask) {
    auto inside = [&](int c) { return ((mask >> c) & 1) != 0; };
    std::array<int, 12> next;
    next.fill(-1);
    std::array<int, 12> in_degree{};
    auto add_segment = [&](int ea, int eb, int reference_inside_corner, int f) {
      // Direct a -> b so that n x d points away from the inside corner, i.e.
      // the outside part of the face lies on the left seen from outside.
      const Vec3d n(kFaceNormals[f][0], kFaceNormals[f][1], kFaceNormals[f][2]);
      const Vec3d pa = edge_midpoint(ea), pb = edge_midpoint(eb);
      const double side = n.cross(pb - pa).dot(corner_position(reference_inside_corner) - 0.5 * (pa + pb));
      if (side > 0) std::swap(ea, eb);
      if (next[ea] != -1) throw std::logic_error("marching cubes: two segments leave one edge");
      next[ea] = eb;
      ++in_degree[eb];
    };
    for (int f = 0; f < 6; ++f) {
      const auto& q = kFaceCorners[f];
      std::vector<int> crossings;  // cube edges of the face whose ends differ
      int any_inside = -1, n_inside = 0;
      for (int s = 0; s < 4; ++s) {
        if (inside(q[s])) any_inside = q[s], ++n_inside;
        if (inside(q[s]) != inside(q[(s + 1) % 4])) crossings.push_back(edge_between(q[s], q[(s + 1) % 4]));
      }
      if (crossings.size() == 2) {
        add_segment(crossings[0], crossings[1], any_inside, f);
      } else if (crossings.size() == 4) {  // ambiguous face: cut off each inside corner
        for (int s = 0; s < 4; ++s)
          if (inside(q[s])) add_segment(edge_between(q[(s + 3) % 4], q[s]), edge_between(q[s], q[(s + 1) % 4]), q[s], f);
      }
    }
    std::array<bool, 12> visited{};
    for (int e = 0; e < 12; ++e) {
      if (next[e] == -1) continue;
      if (in_degree[e] != 1) throw std::logic_error("marching cubes: segments do not form loops");
      if (visited[e]) continue;
      std::vector<int> loop;
      for (int v = e; !visited[v]; v = next[v]) {
        visited[v] = true;
        loop.push_back(v);
      }
      for (const Tri& t : triangulate_loop(loop, share_face)) table.triangles[mask].push_back(t);
    }
  }
  return table;
}

}  // namespace

const std::vector<std::array<std::int8_t, 3>>& mc_case_triangles(int inside_mask) {
  static const CaseTable table = build_case_table();
  if (inside_mask < 0 || inside_mask > 255) throw ParamError("marching cubes: case index must be in 0..255");
  return table.triangles[std::size_t(inside_mask)];
}

}  // namespace detail

MarchingCubes::MarchingCubes(int width, int height, double x0, double y0, MarchingCubesParams params)
    : width_(width), height_(height), x0_(x0), y0_(y0), params_(params) {
  if (width < 1 || height < 1)
    throw ParamError("marching cubes: plane size " + std::to_string(width) + "x" + std::to_string(height) +
                     " must be at least 1x1");
  if (!std::isfinite(x0) || !std::isfinite(y0)) throw ParamError("marching cubes: origin x0, y0 must be finite");
  if (!std::isfinite(params.iso)) throw ParamError("marching cubes: iso must be finite");
  const auto w = std::size_t(width), h = std::size_t(height);
  xedge_bottom_.assign((w - 1) * h, -1);
  xedge_top_.assign((w - 1) * h, -1);
  yedge_bottom_.assign(w * (h - 1), -1);
  yedge_top_.assign(w * (h - 1), -1);
  zedge_.assign(w * h, -1);
  (void)detail::mc_case_triangles(0);  // build the table outside the hot loop
}

void MarchingCubes::add_plane(Grid2f values, double z, const std::vector<std::uint8_t>* active, Grid2f* replaced) {
  const std::string where = "marching cubes: plane " + std::to_string(planes_);
  if (values.width != width_ || values.height != height_ || values.size() != std::size_t(width_) * std::size_t(height_))
    throw ParamError(where + " is " + std::to_string(values.width) + "x" + std::to_string(values.height) + ", expected " +
                     std::to_string(width_) + "x" + std::to_string(height_));
  if (!std::isfinite(z)) throw ParamError(where + ": z is not finite");
  if (planes_ > 0 && !(z > prev_z_))
    throw ParamError(where + ": z = " + std::to_string(z) + " is not greater than the previous z = " +
                     std::to_string(prev_z_));
  int bad = 0;  // a branch-free scan first (it vectorises); the loop below names the pixel
  for (const float v : values.data) bad |= int(!(std::abs(v) <= std::numeric_limits<float>::max()));
  for (int j = 0; bad && j < height_; ++j)
    for (int i = 0; i < width_; ++i)
      if (!std::isfinite(values(i, j)))
        throw InputError("", where + " (z = " + std::to_string(z) + "): value at pixel (" + std::to_string(i) + ", " +
                                 std::to_string(j) + ") is not finite");
  if (active && active->size() != std::size_t(width_ - 1) * std::size_t(height_ - 1))
    throw ParamError(where + ": " + std::to_string(active->size()) + " active-cell flags, expected " +
                     std::to_string(std::size_t(width_ - 1) * std::size_t(height_ - 1)));
  if (planes_ > 0) {
    triangulate_layer(values, z, active);
    if (spill_ && mesh_.triangles.size() >= spill_piece_) {
      spilled_vertices_ += mesh_.vertices.size();
      spill_->take(mesh_);
    }
    for (std::size_t a : {kXBottom, kYBottom, kZ}) {  // then the top plane's become the bottom's
      for (std::int32_t* id : set_[a]) *id = -1;
      set_[a].clear();
    }
    std::swap(xedge_bottom_, xedge_top_);  // swapping moves the buffers: the pointers in set_ stay valid
    std::swap(yedge_bottom_, yedge_top_);
    std::swap(set_[kXBottom], set_[kXTop]);
    std::swap(set_[kYBottom], set_[kYTop]);
  }
  if (replaced) *replaced = std::move(prev_);
  prev_ = std::move(values);
  prev_z_ = z;
  ++planes_;
}

namespace {

// The mesh grows by a quarter, not by doubling: a label partition holds
// every label's growing mesh at once (docs/decisions.md, large label
// stacks), so unused capacity (a quarter at most, not a half) matters more
// than the extra copies. Finish() shrinks it to size either way.
constexpr std::size_t kMeshGrowthDivisor = 4;
constexpr std::size_t kMeshMinGrowth = 1024;  // elements: small meshes grow without many copies

template <class T>
void grow_mesh_array(std::vector<T>& v) {
  if (v.size() == v.capacity()) v.reserve(v.size() + v.size() / kMeshGrowthDivisor + kMeshMinGrowth);
}

}  // namespace

void MarchingCubes::reserve(std::size_t triangles) {
  // A closed Marching Cubes mesh has about half as many vertices as triangles.
  mesh_.vertices.reserve(triangles / 2 + kMeshMinGrowth);
  mesh_.triangles.reserve(triangles);
}

namespace {

// The first non-zero byte of [p, end), or end: the active cells are a thin
// band, so the runs of inactive ones between are skipped 8 bytes at a time.
const std::uint8_t* next_active(const std::uint8_t* p, const std::uint8_t* end) {
  for (std::uint64_t word; end - p >= 8; p += 8) {
    std::memcpy(&word, p, sizeof word);
    if (word != 0) break;
  }
  while (p < end && *p == 0) ++p;
  return p;
}

}  // namespace

void MarchingCubes::triangulate_layer(const Grid2f& top, double z_top, const std::vector<std::uint8_t>* active) {
  const int W = width_, H = height_;
  const float iso = params_.iso;
  const double z_bottom = prev_z_;
  for (int j = 0; j + 1 < H; ++j) {
    const float* b0 = prev_.data.data() + std::size_t(j) * std::size_t(W);
    const float* b1 = b0 + W;
    const float* t0 = top.data.data() + std::size_t(j) * std::size_t(W);
    const float* t1 = t0 + W;
    const std::uint8_t* on = active ? active->data() + std::size_t(j) * std::size_t(W - 1) : nullptr;
    for (int i = 0; i + 1 < W; ++i) {
      if (on && !on[i]) {
        i = int(next_active(on + i, on + (W - 1)) - on);
        if (i + 1 >= W) break;
      }
      const std::array<float, 8> v{b0[i], b0[i + 1], b1[i], b1[i + 1], t0[i], t0[i + 1], t1[i], t1[i + 1]};
      int mask = 0;
      for (int c = 0; c < 8; ++c) mask |= int(v[c] > iso) << c;
      if (mask == 0 || mask == 255) continue;

      const std::size_t xi = std::size_t(j) * std::size_t(W - 1) + std::size_t(i);
      const std::size_t yi = std::size_t(j) * std::size_t(W) + std::size_t(i);
      std::int32_t* slot[12] = {&xedge_bottom_[xi], &xedge_bottom_[xi + std::size_t(W - 1)], &xedge_top_[xi],
                                &xedge_top_[xi + std::size_t(W - 1)], &yedge_bottom_[yi], &yedge_bottom_[yi + 1],
                                &yedge_top_[yi], &yedge_top_[yi + 1], &zedge_[yi], &zedge_[yi + 1],
                                &zedge_[yi + std::size_t(W)], &zedge_[yi + std::size_t(W) + 1]};
      auto vertex = [&](int e) {
        std::int32_t& id = *slot[e];
        if (id >= 0) return id;
        set_[kEdgeArray[std::size_t(e)]].push_back(&id);
        if (spilled_vertices_ + mesh_.vertices.size() >= std::size_t(std::numeric_limits<std::int32_t>::max()))
          throw Error("marching cubes: more than 2^31 - 1 vertices");
        const int a = detail::kCubeEdgeCorners[e][0], b = detail::kCubeEdgeCorners[e][1];
        const double fa = v[a], fb = v[b];
        const double t = std::clamp((double(iso) - fa) / (fb - fa), kMinEdgeFraction, 1.0 - kMinEdgeFraction);
        auto pos = [&](int c) {
          return Vec3d(x0_ + i + (c & 1), y0_ + j + ((c >> 1) & 1), (c >> 2) & 1 ? z_top : z_bottom);
        };
        const Vec3d p = pos(a) + t * (pos(b) - pos(a));
        id = std::int32_t(spilled_vertices_ + mesh_.vertices.size());
        grow_mesh_array(mesh_.vertices);
        mesh_.vertices.push_back(p.cast<float>());
        return id;
      };
      for (const auto& tri : detail::mc_case_triangles(mask)) {
        const std::array<std::int32_t, 3> t{vertex(tri[0]), vertex(tri[1]), vertex(tri[2])};
        grow_mesh_array(mesh_.triangles);
        mesh_.triangles.push_back(t);
      }
    }
  }
}

namespace {
// glibc maps a block this large on its own (the largest dynamic mmap
// threshold): its room beyond the mesh, never touched, is not resident, so
// it is not copied to an exact size (a serial copy into fresh pages).
constexpr std::size_t kMappedBytes = std::size_t(32) << 20;
}  // namespace

TriMesh MarchingCubes::finish() {
  if (spill_) {
    spill_->take(mesh_);
    spilled_vertices_ = 0;
  }
  TriMesh out = std::move(mesh_);
  // Room beyond the mesh (reserve(), or up to a fifth grown by quarters: grow_mesh_array) is held with the
  // mesh until it is written: a heap block's may be resident, so it is shrunk.
  const auto shrink = [](auto& v) {
    if (v.capacity() * sizeof(v[0]) < kMappedBytes) v.shrink_to_fit();
  };
  shrink(out.vertices);
  shrink(out.triangles);
  mesh_ = TriMesh{};
  planes_ = 0;
  prev_ = Grid2f{};
  for (auto* m : {&xedge_bottom_, &xedge_top_, &yedge_bottom_, &yedge_top_, &zedge_}) std::fill(m->begin(), m->end(), -1);
  for (auto& set : set_) set.clear();
  return out;
}

void layer_cells_to_visit(const Grid2<std::int8_t>& bottom, const Grid2<std::int8_t>& top,
                          std::vector<std::uint8_t>& visit) {
  if (bottom.width != top.width || bottom.height != top.height || bottom.width < 1 || bottom.height < 1)
    throw ParamError("marching cubes: side maps of " + std::to_string(bottom.width) + "x" +
                     std::to_string(bottom.height) + " and " + std::to_string(top.width) + "x" +
                     std::to_string(top.height));
  const int w = bottom.width, h = bottom.height;
  std::vector<std::int8_t> both(bottom.data.size());  // the side known in both planes, else 0
  for (std::size_t p = 0; p < both.size(); ++p) both[p] = bottom.data[p] == top.data[p] ? bottom.data[p] : 0;
  visit.resize(std::size_t(w - 1) * std::size_t(h - 1));
  for (int y = 0; y + 1 < h; ++y) {
    const std::int8_t* r0 = both.data() + std::size_t(y) * std::size_t(w);
    const std::int8_t* r1 = r0 + w;
    std::uint8_t* out = visit.data() + std::size_t(y) * std::size_t(w - 1);
    for (int x = 0; x + 1 < w; ++x) {  // branch-free, so it vectorises
      const std::int8_t s = r0[x];
      out[x] = std::uint8_t((s == 0) | (r0[x + 1] != s) | (r1[x] != s) | (r1[x + 1] != s));
    }
  }
}

TriMesh marching_cubes(const std::vector<Grid2f>& planes, const std::vector<double>& z, double x0, double y0,
                       MarchingCubesParams params) {
  if (planes.size() != z.size())
    throw ParamError("marching cubes: " + std::to_string(planes.size()) + " planes but " + std::to_string(z.size()) +
                     " z values");
  if (planes.empty()) return {};
  MarchingCubes mc(planes.front().width, planes.front().height, x0, y0, params);
  for (std::size_t k = 0; k < planes.size(); ++k) mc.add_plane(planes[k], z[k]);
  return mc.finish();
}

}  // namespace isoloft
