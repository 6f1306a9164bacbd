#include "isoloft/eval/volume.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <vector>

namespace isoloft {

long mesh_inside_samples(const TriMesh& mesh, const SampleGrid& g) {
  if (g.nx <= 0 || g.ny <= 0 || g.nz <= 0) return 0;
  // The z of every crossing of each column (i, j) with a triangle.
  std::vector<std::vector<double>> hits(std::size_t(g.nx) * std::size_t(g.ny));
  for (const auto& t : mesh.triangles) {
    const Vec3d a = mesh.vertices[std::size_t(t[0])].cast<double>(), b = mesh.vertices[std::size_t(t[1])].cast<double>(),
                c = mesh.vertices[std::size_t(t[2])].cast<double>();
    const double area = (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
    if (area == 0) continue;  // seen edge-on from above: a column crosses its neighbours instead
    const double x0 = std::min({a.x(), b.x(), c.x()}), x1 = std::max({a.x(), b.x(), c.x()});
    const double y0 = std::min({a.y(), b.y(), c.y()}), y1 = std::max({a.y(), b.y(), c.y()});
    const int i0 = std::max(0, int(std::ceil((x0 - g.origin.x()) / g.step_xy)));
    const int i1 = std::min(g.nx - 1, int(std::floor((x1 - g.origin.x()) / g.step_xy)));
    const int j0 = std::max(0, int(std::ceil((y0 - g.origin.y()) / g.step_xy)));
    const int j1 = std::min(g.ny - 1, int(std::floor((y1 - g.origin.y()) / g.step_xy)));
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) {
        const double px = g.origin.x() + i * g.step_xy, py = g.origin.y() + j * g.step_xy;
        // Barycentric weights of (px, py) in the projected triangle.
        const double wa = ((b.x() - px) * (c.y() - py) - (b.y() - py) * (c.x() - px)) / area;
        const double wb = ((c.x() - px) * (a.y() - py) - (c.y() - py) * (a.x() - px)) / area;
        const double wc = 1 - wa - wb;
        if (wa < 0 || wb < 0 || wc < 0) continue;
        hits[std::size_t(j) * std::size_t(g.nx) + std::size_t(i)].push_back(wa * a.z() + wb * b.z() + wc * c.z());
      }
  }
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, hits.size()), 0L,
      [&](const tbb::blocked_range<std::size_t>& r, long n) {
        for (std::size_t col = r.begin(); col != r.end(); ++col) {
          std::vector<double>& z = hits[col];
          std::sort(z.begin(), z.end());
          // Inside between crossings 2m and 2m + 1: samples in [z[2m], z[2m + 1]).
          for (std::size_t m = 0; m + 1 < z.size(); m += 2) {
            const long k0 = std::max(0L, long(std::ceil((z[m] - g.origin.z()) / g.step_z)));
            const long k1 = std::min(long(g.nz) - 1, long(std::ceil((z[m + 1] - g.origin.z()) / g.step_z)) - 1);
            n += std::max(0L, k1 - k0 + 1);
          }
        }
        return n;
      },
      std::plus<long>());
}

long shape_inside_samples(const Shape& shape, const SampleGrid& g) {
  if (g.nx <= 0 || g.ny <= 0 || g.nz <= 0) return 0;
  return tbb::parallel_reduce(
      tbb::blocked_range<int>(0, g.nz), 0L,
      [&](const tbb::blocked_range<int>& r, long n) {
        for (int k = r.begin(); k != r.end(); ++k)
          for (int j = 0; j < g.ny; ++j)
            for (int i = 0; i < g.nx; ++i)
              n += shape.value(g.origin + Vec3d(i * g.step_xy, j * g.step_xy, k * g.step_z)) > 0;
        return n;
      },
      std::plus<long>());
}

double volume_ratio(const TriMesh& mesh, const Shape& truth, int width, int height, double z_first, double z_last) {
  SampleGrid g;
  g.origin = Vec3d(0, 0, z_first);
  g.step_xy = 1, g.step_z = kVolumeSampleStep;
  g.nx = width, g.ny = height;
  g.nz = int(std::round((z_last - z_first) / kVolumeSampleStep)) + 1;
  const long want = shape_inside_samples(truth, g);
  g.origin += Vec3d(kColumnJitter, kColumnJitter, 0);
  return want > 0 ? double(mesh_inside_samples(mesh, g)) / double(want) : 0.0;
}

}  // namespace isoloft
