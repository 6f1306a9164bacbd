// Polygon scan conversion; see rasterize.h.
#include "isoloft/contour/rasterize.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "isoloft/core/error.h"

namespace isoloft {
namespace {

/// Nearest integer, ties up (the same rule everywhere, so shared vertices
/// map to the same pixel from both edges).
double round_half_up(double v) { return std::floor(v + 0.5); }

/// Calls visit(x, y) for the DDA pixels of p -> q in order, clipped to the
/// grid. Coordinates are checked in double before the cast to int.
template <class Visit>
void visit_segment(const Vec2d& p, const Vec2d& q, int width, int height, Visit&& visit) {
  auto emit = [&](double x, double y) {
    if (x >= 0.0 && y >= 0.0 && x < double(width) && y < double(height)) visit(int(x), int(y));
  };
  emit(round_half_up(p.x()), round_half_up(p.y()));
  const double dx = q.x() - p.x(), dy = q.y() - p.y();
  const bool x_major = std::abs(dx) >= std::abs(dy);
  const double a0 = x_major ? p.x() : p.y(), a1 = x_major ? q.x() : q.y();  // major axis
  const double b0 = x_major ? p.y() : p.x();                                // minor axis
  const double da = x_major ? dx : dy, db = x_major ? dy : dx;
  const double size = x_major ? double(width) : double(height);
  if (da != 0.0) {
    // Integer major coordinates inside the segment and the grid.
    const double lo = std::max(std::ceil(std::min(a0, a1)), 0.0);
    const double hi = std::min(std::floor(std::max(a0, a1)), size - 1.0);
    if (lo <= hi) {
      const int ilo = int(lo), ihi = int(hi);
      const bool up = a1 >= a0;
      for (int k = 0; k <= ihi - ilo; ++k) {
        const int i = up ? ilo + k : ihi - k;
        const double b = round_half_up(b0 + (double(i) - a0) / da * db);
        if (x_major)
          emit(double(i), b);
        else
          emit(b, double(i));
      }
    }
  }
  emit(round_half_up(q.x()), round_half_up(q.y()));
}

}  // namespace

namespace detail {

std::vector<std::array<int, 2>> segment_pixels(const Vec2d& p, const Vec2d& q, int width, int height) {
  std::vector<std::array<int, 2>> out;
  visit_segment(p, q, width, height, [&](int x, int y) {
    if (out.empty() || out.back() != std::array<int, 2>{x, y}) out.push_back({x, y});
  });
  return out;
}

}  // namespace detail

namespace {

void check_polygons(const std::vector<Polygon>& polys, int width, int height) {
  if (width < 0 || height < 0)
    throw ParamError("rasterize_polygons: grid size " + std::to_string(width) + "x" +
                     std::to_string(height) + " is negative");
  for (std::size_t k = 0; k < polys.size(); ++k)
    for (std::size_t i = 0; i < polys[k].points.size(); ++i)
      if (!polys[k].points[i].allFinite())
        throw InputError("", "polygon " + std::to_string(k) + " vertex " + std::to_string(i) +
                                 " is not finite");
}

}  // namespace

Grid2u8 even_odd_inside(const std::vector<Polygon>& polys, int width, int height) {
  check_polygons(polys, width, height);
  Grid2u8 inside(width, height);
  // Per row, the x of every edge crossing the horizontal line through the
  // pixel centres; half-open in y ((a.y > y) != (b.y > y)) so a vertex on
  // the line counts once, as in the crossing-number point-in-polygon test.
  std::vector<std::vector<double>> crossings(static_cast<std::size_t>(height));
  for (const Polygon& poly : polys) {
    const auto& pts = poly.points;
    const std::size_t n = pts.size();
    for (std::size_t i = 0; i < n; ++i) {
      const Vec2d& a = pts[i];
      const Vec2d& b = pts[(i + 1) % n];
      if (a.y() == b.y()) continue;
      const double lo = std::max(std::ceil(std::min(a.y(), b.y())), 0.0);
      const double hi = std::min(std::ceil(std::max(a.y(), b.y())) - 1.0, double(height) - 1.0);
      for (double yd = lo; yd <= hi; yd += 1.0) {
        if ((a.y() > yd) == (b.y() > yd)) continue;  // guard the bucket bounds
        crossings[std::size_t(yd)].push_back(a.x() + (yd - a.y()) * (b.x() - a.x()) / (b.y() - a.y()));
      }
    }
  }
  // A centre is inside if an odd number of crossings lie at or left of it:
  // xs[2k] <= x < xs[2k+1].
  for (int y = 0; y < height; ++y) {
    auto& xs = crossings[std::size_t(y)];
    std::sort(xs.begin(), xs.end());
    for (std::size_t k = 0; k + 1 < xs.size(); k += 2) {
      const double lo = std::max(std::ceil(xs[k]), 0.0);
      const double hi = std::min(std::ceil(xs[k + 1]) - 1.0, double(width) - 1.0);
      for (double x = lo; x <= hi; x += 1.0) inside(int(x), y) = 1;
    }
  }
  return inside;
}

void rasterize_polygons(const std::vector<Polygon>& polys, int width, int height, Grid2u8& contour,
                        Grid2u8& inside) {
  inside = even_odd_inside(polys, width, height);
  contour = Grid2u8(width, height);
  for (const Polygon& poly : polys) {
    const auto& pts = poly.points;
    for (std::size_t i = 0; i < pts.size(); ++i)
      visit_segment(pts[i], pts[(i + 1) % pts.size()], width, height, [&](int x, int y) { contour(x, y) = 1; });
  }
  for (std::size_t i = 0; i < inside.size(); ++i) inside.data[i] |= contour.data[i];
}

std::vector<Vec2d> contour_points(const Grid2u8& contour) {
  std::vector<Vec2d> pts;
  for (int y = 0; y < contour.height; ++y)
    for (int x = 0; x < contour.width; ++x)
      if (contour(x, y)) pts.emplace_back(double(x), double(y));
  return pts;
}

}  // namespace isoloft
