// CGAL exact-distance oracle (see exact_distance.h).
#include "validation/exact_distance.h"

#include <CGAL/Exact_predicates_exact_constructions_kernel.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_2_algorithms.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <unordered_map>

#include "isoloft/core/error.h"

namespace isoloft {
namespace {

using Epeck = CGAL::Exact_predicates_exact_constructions_kernel;
using Epick = CGAL::Exact_predicates_inexact_constructions_kernel;

std::string pixel_name(int x, int y) { return "(" + std::to_string(x) + ", " + std::to_string(y) + ")"; }

void check_grid_args(int width, int height, double x0, double y0, double band, const char* fn) {
  if (width < 0 || height < 0)
    throw ParamError(std::string(fn) + ": grid size " + std::to_string(width) + " x " + std::to_string(height) +
                     " is negative");
  if (!std::isfinite(x0) || !std::isfinite(y0)) throw ParamError(std::string(fn) + ": origin x0, y0 must be finite");
  if (!(band >= 0)) throw ParamError(std::string(fn) + ": band must be >= 0 (got " + std::to_string(band) + ")");
}

void check_segments(const std::vector<Segment2d>& segments, const char* fn) {
  for (std::size_t i = 0; i < segments.size(); ++i)
    if (!segments[i][0].allFinite() || !segments[i][1].allFinite())
      throw InputError("", std::string(fn) + ": segment " + std::to_string(i) + " has a non-finite end point");
}

void check_polygons(const std::vector<Polygon>& polygons, const char* fn) {
  for (std::size_t i = 0; i < polygons.size(); ++i) {
    if (polygons[i].points.size() < 3)
      throw InputError("", std::string(fn) + ": polygon " + std::to_string(i) + " has fewer than 3 vertices");
    for (const Vec2d& p : polygons[i].points)
      if (!p.allFinite()) throw InputError("", std::string(fn) + ": polygon " + std::to_string(i) + " has a non-finite vertex");
  }
}

// Inexact distance from p to segment [a, b] (the candidate filter only).
double approx_distance(const Vec2d& p, const Vec2d& a, const Vec2d& b) {
  const Vec2d ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (p - (a + t * ab)).norm();
}

// The exact kernel of both versions: the minimum over `candidates` of the
// exact squared distance (Epeck), then one rounding to double and a sqrt.
// Equal exact minima give equal doubles, whatever the candidate order.
template <class IndexRange>
double exact_min_distance(const Vec2d& p, const std::vector<Segment2d>& segments, const IndexRange& candidates) {
  const Epeck::Point_2 q(p.x(), p.y());
  Epeck::FT best;
  bool have = false;
  for (const auto i : candidates) {
    const Segment2d& s = segments[std::size_t(i)];
    const Epeck::Segment_2 seg(Epeck::Point_2(s[0].x(), s[0].y()), Epeck::Point_2(s[1].x(), s[1].y()));
    Epeck::FT d2 = CGAL::squared_distance(q, seg);
    if (!have || d2 < best) {
      best = d2;
      have = true;
    }
  }
  if (!have) return std::numeric_limits<double>::infinity();
  return std::sqrt(CGAL::to_double(CGAL::exact(best)));
}

// Uniform bucket grid over the segments' bounding box (the candidate filter).
class SegmentBuckets {
 public:
  explicit SegmentBuckets(const std::vector<Segment2d>& segments) : segs_(segments) {
    if (segments.empty()) return;
    lo_ = hi_ = segments[0][0];
    double total_len = 0;
    for (const auto& s : segments) {
      for (const auto& p : s) {
        lo_ = lo_.cwiseMin(p);
        hi_ = hi_.cwiseMax(p);
      }
      total_len += (s[1] - s[0]).norm();
    }
    // Cell side: at least 2 mean segment lengths (few segments per cell) and
    // sqrt(box area / segments) (a curve's segments then fill ~sqrt(n) cells,
    // so the rings searched from a far pixel stay few); at most 2048 cells per
    // side; a tiny positive size for degenerate inputs.
    const Vec2d ext = hi_ - lo_;
    cell_ = std::max({2.0 * total_len / double(segments.size()), std::sqrt(ext.prod() / double(segments.size())),
                      ext.maxCoeff() / 2048.0, 1e-9});
    nx_ = int(ext.x() / cell_) + 1;
    ny_ = int(ext.y() / cell_) + 1;
    // Relative rounding of the inexact distances (coordinates up to |lo|,
    // |hi|): 1e-9 of the scale covers the ~1e-15 relative error many times.
    margin_ = 1e-9 * (1.0 + lo_.cwiseAbs().maxCoeff() + hi_.cwiseAbs().maxCoeff());
    start_.assign(std::size_t(nx_) * std::size_t(ny_) + 1, 0);
    auto for_cells = [&](const Segment2d& s, auto&& fn) {
      const Vec2d a = s[0].cwiseMin(s[1]), b = s[0].cwiseMax(s[1]);
      const int cx0 = cell_x(a.x()), cx1 = cell_x(b.x()), cy0 = cell_y(a.y()), cy1 = cell_y(b.y());
      for (int cy = cy0; cy <= cy1; ++cy)
        for (int cx = cx0; cx <= cx1; ++cx) fn(std::size_t(cy) * std::size_t(nx_) + std::size_t(cx));
    };
    for (const auto& s : segments) for_cells(s, [&](std::size_t c) { ++start_[c + 1]; });
    for (std::size_t c = 1; c < start_.size(); ++c) start_[c] += start_[c - 1];
    items_.resize(start_.back());
    std::vector<std::uint32_t> fill(start_.begin(), start_.end() - 1);
    for (std::size_t i = 0; i < segments.size(); ++i)
      for_cells(segments[i], [&](std::size_t c) { items_[fill[c]++] = std::uint32_t(i); });
  }

  // Segments that can hold the exact minimum distance from p: every segment
  // whose inexact distance is within margin of the inexact minimum. Empty if
  // the minimum exceeds `band` by more than the margin.
  void candidates(const Vec2d& p, double band, std::vector<std::uint32_t>& out, std::vector<std::uint32_t>& stamp,
                  std::uint32_t& tick, std::vector<std::pair<std::uint32_t, double>>& seen) const {
    out.clear();
    seen.clear();
    if (segs_.empty()) return;
    if (stamp.size() != segs_.size()) stamp.assign(segs_.size(), 0), tick = 0;
    if (++tick == 0) std::fill(stamp.begin(), stamp.end(), 0), tick = 1;
    const int cx = std::clamp(cell_x(p.x()), 0, nx_ - 1), cy = std::clamp(cell_y(p.y()), 0, ny_ - 1);
    double best = std::numeric_limits<double>::infinity();
    const int kmax = std::max({cx, nx_ - 1 - cx, cy, ny_ - 1 - cy});
    for (int k = 0; k <= kmax; ++k) {
      // Every unvisited cell lies in one of the four half-planes of cells at
      // index distance >= k in x or y (those beyond the grid hold none); p's
      // distance to the nearest of them bounds every unvisited segment.
      if (k > 0) {
        constexpr double kNone = std::numeric_limits<double>::infinity();
        auto side = [](double d, bool exists) { return exists ? std::max(0.0, d) : kNone; };
        const double lb = std::min({side(p.x() - (lo_.x() + (cx - k + 1) * cell_), cx - k >= 0),
                                    side(lo_.x() + (cx + k) * cell_ - p.x(), cx + k < nx_),
                                    side(p.y() - (lo_.y() + (cy - k + 1) * cell_), cy - k >= 0),
                                    side(lo_.y() + (cy + k) * cell_ - p.y(), cy + k < ny_)});
        if (lb > std::min(best, band) + margin_) break;
      }
      for (int y = cy - k; y <= cy + k; ++y) {
        if (y < 0 || y >= ny_) continue;
        const bool edge_row = (y == cy - k || y == cy + k);
        for (int x = cx - k; x <= cx + k; x += (edge_row || k == 0) ? 1 : 2 * k) {
          if (x < 0 || x >= nx_) continue;
          const std::size_t c = std::size_t(y) * std::size_t(nx_) + std::size_t(x);
          for (std::uint32_t it = start_[c]; it < start_[c + 1]; ++it) {
            const std::uint32_t s = items_[it];
            if (stamp[s] == tick) continue;
            stamp[s] = tick;
            const double d = approx_distance(p, segs_[s][0], segs_[s][1]);
            best = std::min(best, d);
            seen.emplace_back(s, d);
          }
        }
      }
    }
    if (best > band + margin_) return;
    for (const auto& [s, d] : seen)
      if (d <= best + margin_) out.push_back(s);
  }

 private:
  // Clamped in double first: a pixel far from the segments must not overflow int.
  int cell_x(double x) const { return int(std::clamp(std::floor((x - lo_.x()) / cell_), -1.0, double(nx_))); }
  int cell_y(double y) const { return int(std::clamp(std::floor((y - lo_.y()) / cell_), -1.0, double(ny_))); }

  const std::vector<Segment2d>& segs_;
  Vec2d lo_{0, 0}, hi_{0, 0};
  double cell_ = 1, margin_ = 0;
  int nx_ = 0, ny_ = 0;
  std::vector<std::uint32_t> start_, items_;
};

Grid2d with_sign(Grid2d d, const Grid2u8& inside) {
  for (std::size_t i = 0; i < d.data.size(); ++i)
    if (!inside.data[i]) d.data[i] = -d.data[i];  // NaN (outside the band) stays NaN
  return d;
}

}  // namespace

std::vector<Segment2d> polygon_segments(const std::vector<Polygon>& polygons) {
  std::vector<Segment2d> segs;
  for (const Polygon& poly : polygons)
    for (std::size_t i = 0; i < poly.points.size(); ++i)
      segs.push_back({poly.points[i], poly.points[(i + 1) % poly.points.size()]});
  return segs;
}

namespace detail {

Grid2d exact_unsigned_distance(const std::vector<Segment2d>& segments, int width, int height, double x0, double y0,
                               double band) {
  Grid2d out(width, height, std::numeric_limits<double>::infinity());
  if (segments.empty()) return out;
  const SegmentBuckets buckets(segments);
  tbb::parallel_for(0, height, [&](int y) {
    std::vector<std::uint32_t> cand, stamp;
    std::vector<std::pair<std::uint32_t, double>> seen;
    std::uint32_t tick = 0;
    for (int x = 0; x < width; ++x) {
      const Vec2d p(x0 + x, y0 + y);
      buckets.candidates(p, band, cand, stamp, tick, seen);
      const double d = cand.empty() ? kOutsideBand : exact_min_distance(p, segments, cand);
      out(x, y) = d <= band ? d : kOutsideBand;
    }
  });
  return out;
}

Grid2d exact_unsigned_distance_brute(const std::vector<Segment2d>& segments, int width, int height, double x0,
                                     double y0, double band) {
  Grid2d out(width, height, std::numeric_limits<double>::infinity());
  if (segments.empty()) return out;
  std::vector<std::size_t> all(segments.size());
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = i;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const double d = exact_min_distance(Vec2d(x0 + x, y0 + y), segments, all);
      out(x, y) = d <= band ? d : kOutsideBand;
    }
  return out;
}

Grid2u8 exact_inside(const std::vector<Polygon>& polygons, int width, int height, double x0, double y0) {
  // Predicates on double input are exact with Epick (filtered, exact fallback);
  // bounded_side_2 only uses predicates, so this equals the Epeck answer.
  struct Poly {
    std::vector<Epick::Point_2> pts;
    Vec2d lo, hi;
  };
  std::vector<Poly> polys;
  for (const Polygon& pg : polygons) {
    Poly p;
    p.lo = p.hi = pg.points[0];
    for (const Vec2d& v : pg.points) {
      p.pts.emplace_back(v.x(), v.y());
      p.lo = p.lo.cwiseMin(v);
      p.hi = p.hi.cwiseMax(v);
    }
    polys.push_back(std::move(p));
  }
  Grid2u8 inside(width, height, 0);
  const Epick traits;
  tbb::parallel_for(0, height, [&](int y) {
    for (int x = 0; x < width; ++x) {
      const Vec2d q(x0 + x, y0 + y);
      const Epick::Point_2 cq(q.x(), q.y());
      int odd = 0;
      for (const Poly& p : polys) {
        if (q.x() < p.lo.x() || q.y() < p.lo.y() || q.x() > p.hi.x() || q.y() > p.hi.y()) continue;
        const auto side = CGAL::bounded_side_2(p.pts.begin(), p.pts.end(), cq, traits);
        if (side == CGAL::ON_BOUNDARY) {
          odd = 0;  // on an edge: d = 0, counted outside (documented)
          break;
        }
        if (side == CGAL::ON_BOUNDED_SIDE) odd ^= 1;
      }
      inside(x, y) = std::uint8_t(odd);
    }
  });
  return inside;
}

}  // namespace detail

Grid2d exact_signed_distance(const std::vector<Polygon>& polygons, int width, int height, double x0, double y0,
                             double band) {
  check_grid_args(width, height, x0, y0, band, "exact_signed_distance");
  check_polygons(polygons, "exact_signed_distance");
  const Grid2u8 inside = detail::exact_inside(polygons, width, height, x0, y0);
  return with_sign(detail::exact_unsigned_distance(polygon_segments(polygons), width, height, x0, y0, band), inside);
}

Grid2d exact_signed_distance(const std::vector<Segment2d>& segments, const Grid2u8& inside, double x0, double y0,
                             double band) {
  check_grid_args(inside.width, inside.height, x0, y0, band, "exact_signed_distance");
  check_segments(segments, "exact_signed_distance");
  return with_sign(detail::exact_unsigned_distance(segments, inside.width, inside.height, x0, y0, band), inside);
}

FieldErrorReport compare_grids(const Grid2f& field, const Grid2d& exact) {
  if (field.width != exact.width || field.height != exact.height)
    throw ParamError("compare_grids: field is " + std::to_string(field.width) + " x " + std::to_string(field.height) +
                     " but the exact grid is " + std::to_string(exact.width) + " x " + std::to_string(exact.height));
  FieldErrorReport r;
  double sum = 0;
  for (int y = 0; y < field.height; ++y)
    for (int x = 0; x < field.width; ++x) {
      const double e = exact(x, y);
      if (std::isnan(e)) continue;
      const double f = field(x, y);
      if (std::isnan(f)) throw InputError("", "compare_grids: field is NaN at pixel " + pixel_name(x, y));
      const double err = std::abs(f - e);
      ++r.pixels_checked;
      sum += err;
      if (err > r.max_abs_error || r.worst_x < 0) {
        r.max_abs_error = err;
        r.worst_x = x;
        r.worst_y = y;
        r.worst_field = f;
        r.worst_exact = e;
      }
      if ((f > 0 && e < 0) || (f < 0 && e > 0)) {
        if (r.sign_errors == 0) {
          r.first_sign_error_x = x;
          r.first_sign_error_y = y;
        }
        ++r.sign_errors;
      }
    }
  if (r.pixels_checked > 0) r.mean_abs_error = sum / double(r.pixels_checked);
  return r;
}

FieldErrorReport compare_field(const Grid2f& field, const std::vector<Polygon>& polygons, double x0, double y0,
                               double band) {
  return compare_grids(field, exact_signed_distance(polygons, field.width, field.height, x0, y0, band));
}

FieldErrorReport compare_field(const Grid2f& field, const std::vector<Segment2d>& segments, const Grid2u8& inside,
                               double x0, double y0, double band) {
  if (field.width != inside.width || field.height != inside.height)
    throw ParamError("compare_field: field and inside grids differ in size");
  return compare_grids(field, exact_signed_distance(segments, inside, x0, y0, band));
}

// ---- marching squares -------------------------------------------------------

std::vector<Polygon> zero_set_polygons(const Grid2f& f, double x0, double y0,
                                       const std::function<double(const Vec2d&)>& refine) {
  const int w = f.width, h = f.height;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (std::isnan(f(x, y))) throw InputError("", "zero_set_polygons: f is NaN at pixel " + pixel_name(x, y));
  auto in = [&](int x, int y) { return f(x, y) > 0.0f; };
  auto pos = [&](int x, int y) { return Vec2d(x0 + x, y0 + y); };
  // Grid edge ids: 2 * (y * w + x) for (x, y)-(x+1, y), + 1 for (x, y)-(x, y+1).
  std::unordered_map<std::int64_t, Vec2d> vertex;
  auto edge_vertex = [&](int xa, int ya, int xb, int yb) -> std::int64_t {
    const std::int64_t id = 2 * (std::int64_t(ya) * w + xa) + (yb != ya ? 1 : 0);
    if (vertex.count(id)) return id;
    const double fa = f(xa, ya), fb = f(xb, yb);
    Vec2d pa = pos(xa, ya), pb = pos(xb, yb);
    Vec2d v = pa + (fa / (fa - fb)) * (pb - pa);
    if (refine) {
      // Bisection keeps an inside (> 0) and an outside (<= 0) end.
      double ra = refine(pa), rb = refine(pb);
      if ((ra > 0) == (fa > 0) && (rb > 0) == (fb > 0)) {
        if (!(ra > 0)) std::swap(pa, pb);
        for (int it = 0; it < 200 && (pb - pa).squaredNorm() > 0; ++it) {
          const Vec2d m = 0.5 * (pa + pb);
          if (m == pa || m == pb) break;
          (refine(m) > 0 ? pa : pb) = m;
        }
        v = 0.5 * (pa + pb);
      }
    }
    vertex.emplace(id, v);
    return id;
  };
  std::vector<std::array<std::int64_t, 2>> segs;
  for (int y = 0; y + 1 < h; ++y)
    for (int x = 0; x + 1 < w; ++x) {
      const bool c00 = in(x, y), c10 = in(x + 1, y), c01 = in(x, y + 1), c11 = in(x + 1, y + 1);
      const int mask = c00 | (c10 << 1) | (c11 << 2) | (c01 << 3);  // counter-clockwise corners
      if (mask == 0 || mask == 15) continue;
      // Crossed edges in ring order: bottom (00-10), right (10-11), top (01-11), left (00-01).
      std::int64_t e[4] = {-1, -1, -1, -1};
      if (c00 != c10) e[0] = edge_vertex(x, y, x + 1, y);
      if (c10 != c11) e[1] = edge_vertex(x + 1, y, x + 1, y + 1);
      if (c01 != c11) e[2] = edge_vertex(x, y + 1, x + 1, y + 1);
      if (c00 != c01) e[3] = edge_vertex(x, y, x, y + 1);
      if (mask == 5 || mask == 10) {
        // Saddle: inside corners 00 & 11 (mask 5) or 10 & 01 (mask 10).
        const double centre = refine ? refine(pos(x, y) + Vec2d(0.5, 0.5))
                                     : 0.25 * (double(f(x, y)) + f(x + 1, y) + f(x, y + 1) + f(x + 1, y + 1));
        const bool joined = centre > 0;  // the inside corners connect through the centre
        // Corner k sits between ring edges k-1 and k (corner 0 = 00 between left and bottom).
        // Cut off the corners that are NOT connected: outside ones if joined, inside ones if not.
        const bool cut_inside = !joined;
        const bool corner_in[4] = {c00, c10, c11, c01};
        for (int k = 0; k < 4; ++k)
          if (corner_in[k] == cut_inside) segs.push_back({e[(k + 3) % 4], e[k]});
      } else {
        std::int64_t a = -1;
        for (int k = 0; k < 4; ++k)
          if (e[k] >= 0) {
            if (a < 0) a = e[k];
            else segs.push_back({a, e[k]});
          }
      }
    }
  // Chain: every crossed interior edge is shared by exactly two segments.
  std::unordered_map<std::int64_t, std::array<std::int32_t, 2>> incident;
  for (std::size_t s = 0; s < segs.size(); ++s)
    for (const auto v : segs[s]) {
      auto [it, fresh] = incident.try_emplace(v, std::array<std::int32_t, 2>{-1, -1});
      (it->second[0] < 0 ? it->second[0] : it->second[1]) = std::int32_t(s);
    }
  for (const auto& [v, inc] : incident)
    if (inc[1] < 0) {
      const std::int64_t cell = v / 2;
      throw InputError("", "zero_set_polygons: the zero set leaves the grid near pixel " +
                               pixel_name(int(cell % w), int(cell / w)) + " (pad the field with outside values)");
    }
  std::vector<char> used(segs.size(), 0);
  std::vector<Polygon> polys;
  for (std::size_t s0 = 0; s0 < segs.size(); ++s0) {
    if (used[s0]) continue;
    Polygon poly;
    std::size_t s = s0;
    std::int64_t v = segs[s0][0];
    while (!used[s]) {
      used[s] = 1;
      const Vec2d& p = vertex.at(v);
      if (poly.points.empty() || poly.points.back() != p) poly.points.push_back(p);
      v = segs[s][0] == v ? segs[s][1] : segs[s][0];
      const auto& inc = incident.at(v);
      s = std::size_t(inc[0] == std::int32_t(s) ? inc[1] : inc[0]);
    }
    while (poly.points.size() > 1 && poly.points.front() == poly.points.back()) poly.points.pop_back();
    if (poly.points.size() >= 3) polys.push_back(std::move(poly));
  }
  return polys;
}

}  // namespace isoloft
