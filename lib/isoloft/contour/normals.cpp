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

namespace {

// Even-odd inside test of many points against many polygons in O(log n + k)
// per point (k: edges in the point's row): each edge is filed in the rows of
// a uniform y grid its y extent meets, so a query tests only the edges near
// its y, by the same crossing rule as detail::crossing_parity (same bits).
class EdgeRows {
 public:
  EdgeRows(const std::vector<Polygon>& polygons, const std::vector<Eigen::AlignedBox2d>& boxes, const Eigen::AlignedBox2d& all)
      : polygons_(polygons), boxes_(boxes), y0_(all.min().y()) {
    std::size_t n = 0;
    double extent = 0;  // summed y extent of the edges
    for (const Polygon& p : polygons) {
      const auto& v = p.points;
      n += v.size();
      for (std::size_t i = 0, j = v.size() - 1; i < v.size(); j = i++) extent += std::abs(v[i].y() - v[j].y());
    }
    // Row height: at least the mean edge extent (so an edge meets ~2 rows on
    // average and filing costs O(n)), at least the height / n (so n rows).
    const double height = all.max().y() - y0_;
    h_ = std::max(extent / double(n), height / double(n));
    if (!(h_ > 0)) h_ = 1;
    rows_ = std::size_t(std::min(double(n), std::floor(height / h_))) + 1;
    std::vector<std::uint32_t> count(rows_ + 1, 0);
    auto each_edge = [&](auto&& f) {
      for (std::size_t k = 0; k < polygons.size(); ++k) {
        const auto& v = polygons[k].points;
        for (std::size_t i = 0, j = v.size() - 1; i < v.size(); j = i++) {
          const auto [lo, hi] = std::minmax(v[i].y(), v[j].y());
          for (std::size_t r = row(lo), e = row(hi); r <= e; ++r) f(r, Edge{std::uint32_t(k), std::uint32_t(i), std::uint32_t(j)});
        }
      }
    };
    each_edge([&](std::size_t r, const Edge&) { ++count[r + 1]; });
    for (std::size_t r = 0; r < rows_; ++r) count[r + 1] += count[r];
    start_ = count;
    edges_.resize(count[rows_]);
    each_edge([&](std::size_t r, const Edge& e) { edges_[count[r]++] = e; });
  }

  [[nodiscard]] bool inside(const Vec2d& p) const {
    const std::size_t r = row(p.y());
    bool in = false;
    for (std::size_t e = start_[r]; e < start_[r + 1]; ++e) {
      const Edge& ed = edges_[e];
      if (!boxes_[ed.poly].contains(p)) continue;
      const auto& v = polygons_[ed.poly].points;
      const Vec2d &a = v[ed.i], &b = v[ed.j];
      if ((a.y() > p.y()) != (b.y() > p.y()) && p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x()) in = !in;
    }
    return in;
  }

 private:
  struct Edge {
    std::uint32_t poly, i, j;
  };
  [[nodiscard]] std::size_t row(double y) const {
    return std::min(rows_ - 1, std::size_t(std::max(0.0, std::floor((y - y0_) / h_))));
  }
  const std::vector<Polygon>& polygons_;
  const std::vector<Eigen::AlignedBox2d>& boxes_;
  double y0_, h_ = 1;
  std::size_t rows_ = 1;
  std::vector<std::uint32_t> start_;
  std::vector<Edge> edges_;
};

}  // namespace

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
  const EdgeRows rows(polygons, boxes, all);
  auto inside = [&](const Vec2d& p) { return rows.inside(p); };
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
