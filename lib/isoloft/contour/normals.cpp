#include "isoloft/contour/normals.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <string>

#include "isoloft/core/error.h"

namespace isoloft {
namespace detail {

namespace {
/// Sampled Gaussian g (sum 1) and its derivative dg = -i / sigma^2 * g, i in [-r, r].
void gaussian_kernels(double sigma, std::vector<double>& g, std::vector<double>& dg) {
  const int r = std::max(1, static_cast<int>(std::ceil(3.0 * sigma)));
  g.assign(2 * r + 1, 0.0);
  dg.assign(2 * r + 1, 0.0);
  double sum = 0.0;
  for (int i = -r; i <= r; ++i) sum += g[i + r] = std::exp(-0.5 * i * i / (sigma * sigma));
  for (int i = -r; i <= r; ++i) {
    g[i + r] /= sum;
    dg[i + r] = -i / (sigma * sigma) * g[i + r];
  }
}

Vec2d gradient_with_kernels(const Grid2u8& mask, int x, int y, const std::vector<double>& g,
                            const std::vector<double>& dg) {
  const int r = static_cast<int>(g.size() / 2);
  double gx = 0.0, gy = 0.0;
  for (int j = -r; j <= r; ++j) {
    const int yy = y + j;
    if (yy < 0 || yy >= mask.height) continue;
    for (int i = -r; i <= r; ++i) {
      const int xx = x + i;
      if (xx < 0 || xx >= mask.width || !mask(xx, yy)) continue;
      // Correlation with the derivative kernel: d/dx of sum_k m(k) g(x - k).
      gx += dg[r - i] * g[r - j];
      gy += g[r - i] * dg[r - j];
    }
  }
  return {gx, gy};
}
}  // namespace

Vec2d smoothed_mask_gradient(const Grid2u8& mask, int x, int y, double sigma) {
  std::vector<double> g, dg;
  gaussian_kernels(sigma, g, dg);
  return gradient_with_kernels(mask, x, y, g, dg);
}

bool crossing_parity(const std::vector<Vec2d>& v, const Vec2d& p) {
  bool inside = false;
  if (v.empty()) return false;
  for (std::size_t i = 0, j = v.size() - 1; i < v.size(); j = i++) {
    if ((v[i].y() > p.y()) != (v[j].y() > p.y()) &&
        p.x() < (v[j].x() - v[i].x()) * (p.y() - v[i].y()) / (v[j].y() - v[i].y()) + v[i].x())
      inside = !inside;
  }
  return inside;
}

bool inside_even_odd(const std::vector<Polygon>& polygons, const Vec2d& p) {
  bool inside = false;
  for (const Polygon& poly : polygons) inside ^= crossing_parity(poly.points, p);
  return inside;
}

}  // namespace detail

OrientedPoints contour_normals(const Grid2u8& contour, const Grid2u8& filled_mask, const NormalsParams& params) {
  params_table<NormalsParams>().validate(params);
  if (contour.width != filled_mask.width || contour.height != filled_mask.height)
    throw ParamError("contour normals: contour image " + std::to_string(contour.width) + "x" +
                     std::to_string(contour.height) + " and filled mask " + std::to_string(filled_mask.width) + "x" +
                     std::to_string(filled_mask.height) + " differ in size");
  std::vector<double> g, dg;
  detail::gaussian_kernels(params.sigma, g, dg);
  // A straight mask edge gives |grad| ~ g(0) ~ 0.4 / sigma; 1e-6 of that is
  // "no edge at all" (a symmetric neighbourhood), not a weak one.
  const double min_norm = 1e-6 / params.sigma;
  OrientedPoints out;
  for (int y = 0; y < contour.height; ++y)
    for (int x = 0; x < contour.width; ++x) {
      if (!contour(x, y)) continue;
      const Vec2d grad = detail::gradient_with_kernels(filled_mask, x, y, g, dg);
      const double n = grad.norm();
      if (!(n > min_norm)) {
        ++out.dropped;
        continue;
      }
      out.points.emplace_back(x, y);
      out.normals.push_back(-grad / n);  // the mask rises inward: outward is -grad
    }
  return out;
}

OrientedPoints polygon_points(const std::vector<Polygon>& polygons, double spacing) {
  if (!(spacing > 0.0) || !std::isfinite(spacing))
    throw ParamError("polygon points: spacing must be a finite number > 0 (got " + std::to_string(spacing) + ")");
  Eigen::AlignedBox2d all;
  std::vector<Eigen::AlignedBox2d> boxes;
  for (std::size_t k = 0; k < polygons.size(); ++k) {
    const auto& v = polygons[k].points;
    if (v.size() < 3)
      throw InputError(
          "", "polygon " + std::to_string(k) + " has " + std::to_string(v.size()) + " vertices (need at least 3)");
    Eigen::AlignedBox2d box;
    double area2 = 0.0;
    for (std::size_t i = 0; i < v.size(); ++i) {
      if (!v[i].allFinite())
        throw InputError("", "polygon " + std::to_string(k) + " vertex " + std::to_string(i) + " is not finite");
      box.extend(v[i]);
      const Vec2d& b = v[(i + 1) % v.size()];
      area2 += v[i].x() * b.y() - b.x() * v[i].y();
    }
    if (area2 == 0.0) throw InputError("", "polygon " + std::to_string(k) + " has zero area");
    boxes.push_back(box);
    all.extend(box);
  }
  OrientedPoints out;
  if (polygons.empty()) return out;
  // Side test offset: far below any sample spacing, far above rounding.
  const double eps = 1e-7 * (1.0 + all.diagonal().norm());
  auto inside = [&](const Vec2d& p) {
    bool in = false;
    for (std::size_t k = 0; k < polygons.size(); ++k) {
      if (boxes[k].contains(p)) in ^= detail::crossing_parity(polygons[k].points, p);
    }
    return in;
  };
  for (const Polygon& poly : polygons) {
    const auto& v = poly.points;
    for (std::size_t i = 0; i < v.size(); ++i) {
      const Vec2d a = v[i], b = v[(i + 1) % v.size()];
      const Vec2d d = b - a;
      const double len = d.norm();
      if (len == 0.0) continue;
      const Vec2d m(d.y() / len, -d.x() / len);
      const Vec2d mid = 0.5 * (a + b);
      const bool in_plus = inside(mid + eps * m), in_minus = inside(mid - eps * m);
      const int count = static_cast<int>(std::ceil(len / spacing));
      if (in_plus == in_minus) {  // edge covered twice: not a boundary of the even-odd fill
        out.dropped += static_cast<std::size_t>(count);
        continue;
      }
      const Vec2d normal = in_plus ? Vec2d(-m) : m;
      for (int s = 0; s < count; ++s) {
        out.points.push_back(a + d * (static_cast<double>(s) / count));
        out.normals.push_back(normal);
      }
    }
  }
  return out;
}

}  // namespace isoloft
