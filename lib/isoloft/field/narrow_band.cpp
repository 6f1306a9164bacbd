#include "isoloft/field/narrow_band.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <utility>

#include "isoloft/core/error.h"
#include "isoloft/field/edt.h"

namespace isoloft {
namespace {

constexpr double kSqrt2 = 1.41421356237309504880;

Vec2d lerp(const Vec2d& a, const Vec2d& b, double t) { return a + t * (b - a); }

// Newton projection of p onto f = 0 along the gradient (central differences).
// A step is taken only if it lowers |f| and stays within kMaxMove of the start,
// so a bad gradient never drags a point off its cell.
Vec2d project_to_zero(const ImplicitFn& f, Vec2d p, int iterations) {
  constexpr double kStep = 1e-4;    // px; central-difference step
  constexpr double kMaxMove = 0.5;  // px; a chord is at most sqrt(2)/4 px from the curve for R >= 1
  const Vec2d start = p;
  double fp = f(p);
  for (int it = 0; it < iterations && fp != 0.0; ++it) {
    const Vec2d dx(kStep, 0.0), dy(0.0, kStep);
    const Vec2d g((f(p + dx) - f(p - dx)) / (2.0 * kStep), (f(p + dy) - f(p - dy)) / (2.0 * kStep));
    const double g2 = g.squaredNorm();
    if (!(g2 > 0.0) || !std::isfinite(g2)) break;
    const Vec2d q = p - (fp / g2) * g;
    const double fq = f(q);
    if (!(std::abs(fq) < std::abs(fp)) || (q - start).norm() > kMaxMove) break;
    const double moved = (q - p).norm();
    p = q;
    fp = fq;
    if (moved < 1e-12) break;
  }
  return p;
}

}  // namespace

namespace detail {

Vec2d closest_point_on_segment(const Vec2d& p, const Vec2d& a, const Vec2d& b) {
  const Vec2d ab = b - a;
  const double len2 = ab.squaredNorm();
  if (len2 <= 0.0) return a;
  const double t = std::clamp((p - a).dot(ab) / len2, 0.0, 1.0);
  return a + t * ab;
}

Vec2d edge_zero(const Vec2d& pa, double fa, const Vec2d& pb, double fb, const ImplicitFn& f, int iterations) {
  // Samples of opposite classification: fa - fb != 0, t in [0, 1].
  const double t_lin = fa / (fa - fb);
  const Vec2d linear = lerp(pa, pb, t_lin);
  if (!f || iterations <= 0) return linear;
  double ga = f(pa), gb = f(pb);
  if ((ga > 0.0) == (gb > 0.0) || !std::isfinite(ga) || !std::isfinite(gb)) return linear;
  if (ga == 0.0) return pa;
  if (gb == 0.0) return pb;
  // Illinois: regula falsi that halves the stale end's value when the same end
  // moves twice, so convergence stays superlinear (Dowell & Jarratt 1971).
  double lo = 0.0, hi = 1.0;
  int last = 0;  // -1: lo moved last, +1: hi moved last
  double t = ga / (ga - gb);
  for (int it = 0; it < iterations; ++it) {
    const double gt = f(lerp(pa, pb, t));
    if (gt == 0.0 || !std::isfinite(gt)) break;
    if ((gt > 0.0) == (ga > 0.0)) {
      lo = t;
      ga = gt;
      if (last == -1) gb *= 0.5;
      last = -1;
    } else {
      hi = t;
      gb = gt;
      if (last == +1) ga *= 0.5;
      last = +1;
    }
    if (hi - lo < 1e-13) break;
    t = lo + (hi - lo) * ga / (ga - gb);
  }
  return lerp(pa, pb, t);
}

ZeroSet marching_squares(const Grid2f& s, const ImplicitFn& f, int refine_iterations, int segment_splits) {
  ZeroSet zs;
  std::vector<Segment2d>& segments = zs.segments;
  std::vector<std::array<std::int32_t, 2>> ends;  // vertex ids of each segment's end points
  const int w = s.width, h = s.height;
  if (w < 2 || h < 2) return zs;
  // Each edge vertex is computed once and shared by both cells: the polyline
  // is watertight and f is evaluated once per crossed edge. Vertex ids of the
  // cell row's edges only: its top and bottom horizontal edges (the bottom
  // ones become the next row's top) and its vertical edges.
  const auto cells = std::size_t(w - 1), pixels = std::size_t(w);
  std::vector<std::int32_t> htop(cells, -1), hbottom(cells), vrow(pixels);
  std::vector<Vec2d> verts;
  int y = 0;  // the cell row
  auto hvert = [&](int x, int yy) {  // edge (x, yy) - (x + 1, yy), yy = y or y + 1; returns the vertex id
    std::int32_t& id = (yy == y ? htop : hbottom)[std::size_t(x)];
    if (id < 0) {
      id = std::int32_t(verts.size());
      verts.push_back(edge_zero(Vec2d(x, yy), s(x, yy), Vec2d(x + 1, yy), s(x + 1, yy), f, refine_iterations));
    }
    return id;
  };
  auto vvert = [&](int x) {  // edge (x, y) - (x, y + 1)
    std::int32_t& id = vrow[std::size_t(x)];
    if (id < 0) {
      id = std::int32_t(verts.size());
      verts.push_back(edge_zero(Vec2d(x, y), s(x, y), Vec2d(x, y + 1), s(x, y + 1), f, refine_iterations));
    }
    return id;
  };
  auto emit = [&](std::int32_t ia, std::int32_t ib) {
    std::int32_t prev = ia;
    if (segment_splits > 1 && f) {
      const Vec2d a = verts[ia], b = verts[ib];
      for (int k = 1; k < segment_splits; ++k) {
        const auto id = std::int32_t(verts.size());
        verts.push_back(project_to_zero(f, lerp(a, b, double(k) / segment_splits), std::max(refine_iterations, 1)));
        ends.push_back({prev, id});
        prev = id;
      }
    }
    ends.push_back({prev, ib});
  };
  // Per cell of the row, its corners' sides (v0 bit 0 .. v3 bit 3); 0 and 15
  // (no crossing) are skipped eight cells at a time.
  std::vector<std::uint8_t> in_top(pixels), in_bottom(pixels), code(cells);
  const auto sides = [&](int row, std::vector<std::uint8_t>& out) {
    const float* v = &s.data[s.index(0, row)];
    for (int x = 0; x < w; ++x) out[std::size_t(x)] = v[x] > 0.0f;
  };
  sides(0, in_bottom);
  constexpr std::uint64_t kAllIn = 0x0F0F0F0F0F0F0F0FULL;
  for (; y + 1 < h; ++y) {
    std::swap(in_top, in_bottom);
    sides(y + 1, in_bottom);
    if (y > 0) std::swap(htop, hbottom);
    std::fill(hbottom.begin(), hbottom.end(), -1);
    std::fill(vrow.begin(), vrow.end(), -1);
    for (int x = 0; x + 1 < w; ++x)
      code[std::size_t(x)] = std::uint8_t(in_top[std::size_t(x)] | in_top[std::size_t(x) + 1] << 1 |
                                          in_bottom[std::size_t(x) + 1] << 2 | in_bottom[std::size_t(x)] << 3);
    for (int x = 0; x + 1 < w; ++x) {
      if (x + 8 <= w - 1) {
        std::uint64_t eight;
        std::memcpy(&eight, &code[std::size_t(x)], sizeof eight);
        if (eight == 0 || eight == kAllIn) {
          x += 7;
          continue;
        }
      }
      // Corners v0 (x,y), v1 (x+1,y), v2 (x+1,y+1), v3 (x,y+1);
      // edges e0 = v0v1, e1 = v1v2, e2 = v3v2, e3 = v0v3.
      const int c = code[std::size_t(x)];
      if (c == 0 || c == 15) continue;
      auto e = [&](int k) {
        switch (k) {
          case 0: return hvert(x, y);
          case 1: return vvert(x + 1);
          case 2: return hvert(x, y + 1);
          default: return vvert(x);
        }
      };
      // Edges whose corners differ, in order e0..e3.
      const bool crossed[4] = {bool((c ^ (c >> 1)) & 1), bool(((c >> 1) ^ (c >> 2)) & 1),
                               bool(((c >> 2) ^ (c >> 3)) & 1), bool(((c >> 3) ^ c) & 1)};
      if (c == 5 || c == 10) {
        // Saddle: decide by f at the cell centre (bilinear mean without f).
        const double centre = f ? f(Vec2d(x + 0.5, y + 0.5))
                                : 0.25 * (double(s(x, y)) + s(x + 1, y) + s(x + 1, y + 1) + s(x, y + 1));
        const bool centre_in = centre > 0.0;
        // Segment (e0,e1) cuts off v1, (e2,e3) cuts off v3; (e3,e0) v0, (e1,e2) v2.
        // Cut off the two corners whose class differs from the centre's.
        const bool cut_odd = (c == 5) == centre_in;  // v1, v3 differ from the centre
        if (cut_odd) {
          emit(e(0), e(1));
          emit(e(2), e(3));
        } else {
          emit(e(3), e(0));
          emit(e(1), e(2));
        }
        continue;
      }
      int k0 = -1, k1 = -1;
      for (int k = 0; k < 4; ++k) {
        if (!crossed[k]) continue;
        (k0 < 0 ? k0 : k1) = k;
      }
      emit(e(k0), e(k1));
    }
  }
  // Each vertex lies on one cell edge, used by one segment in each of the (at
  // most two) cells sharing that edge, so it touches at most two segments.
  std::vector<std::array<std::int32_t, 2>> at(verts.size(), {-1, -1});
  segments.reserve(ends.size());
  for (std::size_t k = 0; k < ends.size(); ++k) {
    segments.push_back({verts[ends[k][0]], verts[ends[k][1]]});
    for (std::int32_t v : ends[k]) (at[v][0] < 0 ? at[v][0] : at[v][1]) = std::int32_t(k);
  }
  zs.links.resize(ends.size());
  for (std::size_t k = 0; k < ends.size(); ++k)
    for (int e = 0; e < 2; ++e) {
      const auto& a = at[ends[k][e]];
      zs.links[k][e] = a[0] == std::int32_t(k) ? a[1] : a[0];
    }
  return zs;
}

Grid2d distance_to_segments_brute(const std::vector<Segment2d>& segments, int width, int height) {
  Grid2d out(width, height, std::numeric_limits<double>::infinity());
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const Vec2d p(x, y);
      double best = std::numeric_limits<double>::infinity();
      for (const auto& sg : segments) best = std::min(best, (p - closest_point_on_segment(p, sg[0], sg[1])).squaredNorm());
      out(x, y) = std::sqrt(best);
    }
  }
  return out;
}

}  // namespace detail

namespace detail {

void fill_band(NarrowBandResult& r, double bw) {
  const int w = r.inside.width, h = r.inside.height;
  r.known = Grid2u8(w, h, 0);
  r.nearest_segment = Grid2i(w, h, -1);

  // Exact distance to the nearest segment for every pixel within the band:
  // each segment visits the pixels of its bounding box grown by band_width.
  // Work is O(#segments * band_width^2), i.e. proportional to the curve length.
  std::vector<double> best(r.inside.size(), std::numeric_limits<double>::infinity());
  for (std::size_t k = 0; k < r.segments.size(); ++k) {
    const Segment2d& sg = r.segments[k];
    const int x0 = std::max(0, int(std::ceil(std::min(sg[0].x(), sg[1].x()) - bw)));
    const int x1 = std::min(w - 1, int(std::floor(std::max(sg[0].x(), sg[1].x()) + bw)));
    const int y0 = std::max(0, int(std::ceil(std::min(sg[0].y(), sg[1].y()) - bw)));
    const int y1 = std::min(h - 1, int(std::floor(std::max(sg[0].y(), sg[1].y()) + bw)));
    // closest_point_on_segment's arithmetic, the segment's part once.
    const double ax = sg[0].x(), ay = sg[0].y(), abx = sg[1].x() - ax, aby = sg[1].y() - ay;
    const double len2 = abx * abx + aby * aby;
    for (int y = y0; y <= y1; ++y) {
      double* row_best = &best[r.nearest_segment.index(0, y)];
      std::int32_t* row_seg = &r.nearest_segment.data[r.nearest_segment.index(0, y)];
      for (int x = x0; x <= x1; ++x) {
        double cx = ax, cy = ay;
        if (!(len2 <= 0.0)) {
          const double t = std::clamp(((x - ax) * abx + (y - ay) * aby) / len2, 0.0, 1.0);
          cx = ax + t * abx, cy = ay + t * aby;
        }
        const double ex = x - cx, ey = y - cy, d2 = ex * ex + ey * ey;
        if (d2 < row_best[x]) {
          row_best[x] = d2;
          row_seg[x] = std::int32_t(k);
        }
      }
    }
  }
  r.distance = Grid2f(w, h);
  const double bw2 = bw * bw;
  // Raw pointers: a byte store may alias a vector's own pointer, which would
  // be loaded again on every pixel.
  const std::uint8_t* inside = r.inside.data.data();
  std::uint8_t* known = r.known.data.data();
  float* distance = r.distance.data.data();
  std::int32_t* nearest = r.nearest_segment.data.data();
  for (std::size_t i = 0, n = best.size(); i < n; ++i) {
    const float sign = inside[i] ? 1.0f : -1.0f;
    const bool in_band = best[i] <= bw2;
    known[i] = in_band;
    distance[i] = sign * (in_band ? float(std::sqrt(best[i])) : kNoSurfaceDistance);
    if (!in_band) nearest[i] = -1;
  }
}

}  // namespace detail

NarrowBandResult polygon_narrow_band(const std::vector<Polygon>& polygons, const Grid2u8& inside,
                                     const NarrowBandParams& params) {
  params_table<NarrowBandParams>().validate(params);
  if (inside.empty()) throw InputError("polygon narrow band", "grid is empty");
  NarrowBandResult r;
  r.inside = inside;
  for (const Polygon& poly : polygons) {
    // The polygon's edges without zero-length ones (repeated vertices), closed.
    std::vector<Vec2d> v;
    for (const Vec2d& q : poly.points)
      if (v.empty() || q != v.back()) v.push_back(q);
    while (v.size() > 1 && v.front() == v.back()) v.pop_back();
    if (v.size() < 2) continue;
    const auto first = std::int32_t(r.segments.size()), n = std::int32_t(v.size());
    for (std::int32_t i = 0; i < n; ++i) {
      r.segments.push_back({v[std::size_t(i)], v[std::size_t((i + 1) % n)]});
      r.links.push_back({first + (i + n - 1) % n, first + (i + 1) % n});
    }
  }
  detail::fill_band(r, params.band_width);
  return r;
}

NarrowBandResult narrow_band_distance(const Grid2f& f_samples, const ImplicitFn& f, const NarrowBandParams& params) {
  params_table<NarrowBandParams>().validate(params);
  if (f_samples.empty()) throw InputError("implicit samples", "grid is empty");
  const int w = f_samples.width, h = f_samples.height;
  int any_nan = 0;  // one pass without a branch (an int: vectorised), then the first NaN named
  for (const float v : f_samples.data) any_nan |= v != v;
  if (any_nan)
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        if (std::isnan(f_samples(x, y)))
          throw InputError("implicit samples", "NaN at pixel (" + std::to_string(x) + ", " + std::to_string(y) + ")");

  NarrowBandResult r;
  detail::ZeroSet zs = detail::marching_squares(f_samples, f, params.refine_iterations, params.segment_splits);
  r.segments = std::move(zs.segments);
  r.links = std::move(zs.links);
  r.inside = Grid2u8(w, h, 0);
  const float* samples = f_samples.data.data();
  std::uint8_t* inside = r.inside.data.data();  // raw: see fill_band
  for (std::size_t i = 0, n = f_samples.size(); i < n; ++i) inside[i] = samples[i] > 0.0f ? 1 : 0;
  detail::fill_band(r, params.band_width);
  return r;
}

}  // namespace isoloft
