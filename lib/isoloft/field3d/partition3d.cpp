// @file field3d/partition3d.cpp
// @brief The labels' groups, one grid per group, and each label's surface as
// the zero set of its field minus its neighbours' largest.
#include "isoloft/field3d/partition3d.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>

#include "isoloft/core/error.h"
#include "isoloft/field3d/image_sections.h"
#include "isoloft/mesh/marching_cubes.h"

namespace isoloft {
namespace detail {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
using Box = std::array<Vec3d, 2>;

/// The contours' box of `label` over every section (empty box if none).
Box contour_box(const std::vector<Section>& sections, std::uint32_t label) {
  Box b{Vec3d::Constant(kInf), Vec3d::Constant(-kInf)};
  for (const Section& s : sections)
    for (const SectionContour& c : s.contours)
      if (c.label == label)
        for (const Vec2d& p : c.points) {
          const Vec3d w = s.pose.to_world(p);
          b[0] = b[0].cwiseMin(w);
          b[1] = b[1].cwiseMax(w);
        }
  return b;
}

/// The label's polylines per section (plane_section_distance()'s drawn contours).
std::vector<std::vector<std::vector<Vec2d>>> label_polylines(const std::vector<Section>& sections, std::uint32_t label) {
  std::vector<std::vector<std::vector<Vec2d>>> out(sections.size());
  for (std::size_t i = 0; i < sections.size(); ++i)
    for (const SectionContour& c : sections[i].contours)
      if (c.label == label) out[i].push_back(c.points);
  return out;
}

/// A node where two labels' fields tie exactly (a symmetric drawing puts
/// such nodes on the shared face) goes to the lower label index by this much
/// (cells): zero would be outside for both (Marching Cubes: inside iff > 0),
/// and each would place its vertex 1e-4 of an edge off the node on its own
/// side, two vertices where one is shared. A millionth of a cell moves no
/// vertex measurably.
constexpr double kTieBreak = 1e-6;

/// The union term's offset (cells): on a shared face both fields are about
/// 0 (each label's drawn boundary runs along it) and may both be slightly
/// negative there, which the union alone calls outside; the lift keeps such
/// nodes in the union (g_l = -g_m) down to -0.017 cell each, and moves a
/// surface away from the other labels outward by half of it (0.01 cell).
/// A lift of 1 cell fading over a cell of both fields closed more of the
/// face but made specks of a label outside both (docs/decisions.md).
constexpr double kUnionLift = 0.02;

/// R-function union (Rvachev): positive iff a > 0 or b > 0, symmetric.
double r_union(double a, double b) { return a + b + std::sqrt(a * a + b * b); }

/// Zero set of g_l (partition3d.h) on the common grid of `ref`, padded with
/// a layer at -band so the mesh closes; world mm.
TriMesh partition_mesh(const std::vector<Field3dResult>& fields, std::size_t l, double band) {
  const Field3dResult& ref = fields[l];
  const int W = ref.nx + 2, H = ref.ny + 2;
  MarchingCubes mc(W, H, -1, -1);
  for (int k = -1; k <= ref.nz; ++k) {
    Grid2f plane(W, H, float(-band));
    if (k >= 0 && k < ref.nz)
      for (int j = 0; j < ref.ny; ++j)
        for (int i = 0; i < ref.nx; ++i) {
          const std::size_t n = std::size_t(i) + std::size_t(ref.nx) * (std::size_t(j) + std::size_t(ref.ny) * std::size_t(k));
          double others = -std::numeric_limits<double>::infinity();
          std::size_t top = l;  // the other label of the largest field
          for (std::size_t m = 0; m < fields.size(); ++m)
            if (m != l && fields[m].field[n] > others) others = fields[m].field[n], top = m;
          const double f = ref.field[n];
          // Near a shared face f - others is the neighbour's value negated
          // exactly (and rounded to float alike), so both interpolate the
          // same crossing.
          double d = f - others;
          if (d == 0) d = l < top ? kTieBreak : -kTieBreak;
          plane(i + 1, j + 1) = float(std::min(d, 2 * r_union(f, others) + kUnionLift));
        }
    mc.add_plane(std::move(plane), k);
  }
  TriMesh mesh = mc.finish();
  for (Vec3f& v : mesh.vertices) v = (ref.origin + ref.spacing * v.cast<double>()).cast<float>();
  return mesh;
}

}  // namespace

Field3dParams group_params(const std::vector<Section>& sections, const std::vector<std::uint32_t>& labels,
                           const std::vector<std::size_t>& group, const Field3dParams& params, double pixel) {
  Field3dParams p = params;
  if (group.size() > 1) {  // one grid: the box of every label of the group
    Box box{Vec3d::Constant(kInf), Vec3d::Constant(-kInf)};
    for (std::size_t i : group) {
      const Box b = contour_box(sections, labels[i]);
      box[0] = box[0].cwiseMin(b[0]);
      box[1] = box[1].cwiseMax(b[1]);
    }
    p.box = box;
  }
  // Pixel input: the pixel rows (band, contour weight) and pixel cells over the group's box (the label's own
  // box when alone), as pixel_params() sizes one label's grid.
  if (pixel > 0) {
    p = pixel_rows(p);
    p.resolution = pixel_resolution(p.box ? *p.box : contour_box(sections, labels[group[0]]), pixel, sections, p);
  }
  return p;
}

std::vector<std::vector<std::size_t>> overlapping_labels(const std::vector<Section>& sections,
                                                         const std::vector<std::uint32_t>& labels, double margin) {
  const std::size_t n = labels.size();
  std::vector<Box> grid(n);
  for (std::size_t i = 0; i < n; ++i) {
    grid[i] = contour_box(sections, labels[i]);
    const double pad = margin * (grid[i][1] - grid[i][0]).norm();
    grid[i][0] -= Vec3d::Constant(pad);
    grid[i][1] += Vec3d::Constant(pad);
  }
  std::vector<std::size_t> root(n);
  std::iota(root.begin(), root.end(), 0);
  const auto find = [&](std::size_t a) {
    while (root[a] != a) a = root[a] = root[root[a]];
    return a;
  };
  for (std::size_t a = 0; a < n; ++a)
    for (std::size_t b = a + 1; b < n; ++b)
      if ((grid[a][0].array() <= grid[b][1].array()).all() && (grid[b][0].array() <= grid[a][1].array()).all())
        root[std::max(find(a), find(b))] = std::min(find(a), find(b));
  std::vector<std::vector<std::size_t>> groups;
  std::vector<std::size_t> slot(n, n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t r = find(i);
    if (slot[r] == n) {
      slot[r] = groups.size();
      groups.emplace_back();
    }
    groups[slot[r]].push_back(i);
  }
  return groups;
}

}  // namespace detail

Partition3dResult reconstruct_partition(const std::vector<Section>& sections, const std::vector<std::uint32_t>& labels,
                                        const Field3dParams& params, double pixel) {
  using namespace detail;
  const auto start = std::chrono::steady_clock::now();
  if (labels.empty()) throw ParamError("field3d partition: no label to reconstruct");
  for (std::size_t i = 0; i < labels.size(); ++i)
    if (std::count(labels.begin(), labels.end(), labels[i]) > 1)
      throw ParamError("field3d partition: label " + std::to_string(labels[i]) + " asked for twice");
  if (params.box) throw ParamError("field3d partition: the grid's box is set per group of labels, not given");
  Partition3dResult res;
  res.objects.resize(labels.size());
  for (const std::vector<std::size_t>& group : overlapping_labels(sections, labels, params.margin)) {
    const std::size_t g = res.groups.size();
    res.groups.emplace_back();
    const Field3dParams p = group_params(sections, labels, group, params, pixel);
    std::vector<Field3dResult> fields;
    for (std::size_t i : group) {
      res.groups[g].push_back(labels[i]);
      fields.push_back(reconstruct_sections(sections, labels[i], p));
    }
    for (std::size_t k = 0; k < group.size(); ++k) {
      Partition3dObject& ob = res.objects[group[k]];
      ob.label = labels[group[k]];
      ob.group = g;
      ob.conflicts = fields[k].conflicts;
      ob.warnings = fields[k].warnings;
      if (group.size() == 1) {  // alone: reconstruct_sections()'s own surface and residuals
        ob.mesh = std::move(fields[k].mesh);
        ob.check = fields[k].check;
        ob.planes = std::move(fields[k].planes);
        ob.stats = solve_stats(fields[k], &ob.planes);
        continue;
      }
      ob.mesh = partition_mesh(fields, k, p.band);
      ob.check = check_mesh(ob.mesh);
      const auto polys = label_polylines(sections, ob.label);
      ob.planes.resize(sections.size());
      for (std::size_t i = 0; i < sections.size(); ++i) {
        ob.planes[i] = plane_section_distance(ob.mesh, sections[i].pose, polys[i]);
        ob.planes[i].section = i;
      }
      ob.stats = solve_stats(fields[k], &ob.planes);
    }
  }
  res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return res;
}

Field3dWork estimate_partition(const std::vector<Section>& sections, const std::vector<std::uint32_t>& labels,
                               std::uint32_t label, const Field3dParams& params, double pixel) {
  using namespace detail;
  Field3dWork own, peak;
  for (const std::vector<std::size_t>& group : overlapping_labels(sections, labels, params.margin)) {
    const Field3dParams p = group_params(sections, labels, group, params, pixel);
    double solve = 0, held = 0;  // the group's largest solve; its fields and meshes held together
    for (const std::size_t i : group) {
      const Field3dWork w = estimate_sections(sections, labels[i], p);
      if (labels[i] == label) own = w;
      solve = std::max(solve, w.solve_bytes);
      held += w.field_bytes + w.mesh_bytes;
    }
    peak.solve_bytes = std::max(peak.solve_bytes, solve + held);
  }
  own.solve_bytes = peak.solve_bytes;
  return own;
}

Partition3dObject SharedPartition::take(const std::vector<Section>& sections, std::uint32_t label,
                                        const Field3dParams& params, double pixel, double& seconds,
                                        const std::function<void(bool solves)>& before) {
  const auto at = std::find(labels_.begin(), labels_.end(), label);
  if (at == labels_.end()) throw ParamError("field3d partition: label " + std::to_string(label) + " is not in it");
  const std::lock_guard lock(mutex_);
  seconds = 0;
  if (before) before(!result_);
  if (!result_) {
    result_ = reconstruct_partition(sections, labels_, params, pixel);  // an error leaves it unset: the next taker throws too
    taken_.assign(labels_.size(), false);
    seconds = result_->seconds;
  }
  const std::size_t i = std::size_t(at - labels_.begin());
  if (taken_[i]) throw ParamError("field3d partition: label " + std::to_string(label) + " taken twice");
  taken_[i] = true;
  return std::move(result_->objects[i]);
}

}  // namespace isoloft
