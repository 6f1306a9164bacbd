// Parts of a slice field and their matches (interp/track_graph.h).
#include "isoloft/interp/track_graph.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>

#include "isoloft/contour/fill.h"
#include "isoloft/field/edt.h"

namespace isoloft::detail {

namespace {

// A pixel's own second moment about its centre, px^2 (a unit square's).
constexpr double kPixelMoment = 1.0 / 12.0;
// Floor of a semi-extent's variance, px^2: a one-pixel-wide part's across.
constexpr double kMinVariance = 1e-6;

void grow(PixelBox& b, int x, int y) {
  if (b.empty()) {
    b = {x, y, x + 1, y + 1};
    return;
  }
  b.x0 = std::min(b.x0, x), b.y0 = std::min(b.y0, y), b.x1 = std::max(b.x1, x + 1), b.y1 = std::max(b.y1, y + 1);
}

}  // namespace

TrackParts track_parts(const Grid2f& field, float iso) {
  TrackParts out;
  const int w = field.width, h = field.height;
  Grid2u8 inside(w, h);
  for (std::size_t i = 0; i < field.size(); ++i) inside.data[i] = field.data[i] > iso;
  const int n = label_components(inside, true, true, out.labels);
  out.parts.resize(std::size_t(n));
  if (n == 0) return out;
  // Centroids, then central moments (two passes: no cancellation far from the origin).
  std::vector<double> sx(std::size_t(n), 0.0), sy(std::size_t(n), 0.0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (const int l = out.labels(x, y); l >= 0) {
        TrackPart& p = out.parts[std::size_t(l)];
        ++p.pixels, sx[std::size_t(l)] += x, sy[std::size_t(l)] += y;
        grow(p.box, x, y);
      }
  for (int l = 0; l < n; ++l) {
    TrackPart& p = out.parts[std::size_t(l)];
    p.centroid = Vec2d(sx[std::size_t(l)] / double(p.pixels), sy[std::size_t(l)] / double(p.pixels));
  }
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (const int l = out.labels(x, y); l >= 0) {
        TrackPart& p = out.parts[std::size_t(l)];
        const double dx = x - p.centroid.x(), dy = y - p.centroid.y();
        p.sxx += dx * dx, p.syy += dy * dy, p.sxy += dx * dy;
      }
  for (TrackPart& p : out.parts) {
    p.sxx /= double(p.pixels), p.syy /= double(p.pixels), p.sxy /= double(p.pixels);
    // Principal axes of the region as a union of unit squares.
    const double a = p.sxx + kPixelMoment, b = p.syy + kPixelMoment;
    const double tr = a + b, det = a * b - p.sxy * p.sxy;
    const double l1 = 0.5 * tr + std::sqrt(std::max(0.25 * tr * tr - det, 0.0));
    const double l2 = std::max(tr - l1, 1e-9);
    p.angle = 0.5 * std::atan2(2 * p.sxy, a - b);
    p.anisotropy = std::sqrt(l1 / l2);
  }
  if (n > 1) out.owner = nearest_label(out.labels);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (field(x, y) > iso - kTrackShell) grow(out.parts[std::size_t(n > 1 ? out.owner(x, y) : 0)].shell, x, y);
  return out;
}

std::pair<double, double> part_extents(const TrackPart& p, const Vec2d& u) {
  const Vec2d v(-u.y(), u.x());
  auto variance = [&](const Vec2d& e) {
    return std::max(e.x() * e.x() * p.sxx + 2 * e.x() * e.y() * p.sxy + e.y() * e.y() * p.syy - kPixelMoment,
                    kMinVariance);
  };
  return {2 * std::sqrt(variance(u)), 2 * std::sqrt(variance(v))};
}

BridgeTest bridge_test(const TrackPart& a, const TrackPart& b, double h, const TrackParams& params) {
  const Vec2d d = b.centroid - a.centroid;
  BridgeTest r;
  r.distance = d.norm();
  if (r.distance < 1e-9) {
    r.ok = true;
    return r;
  }
  const Vec2d u = d / r.distance;
  const auto [a_a, b_a] = part_extents(a, u);
  const auto [a_b, b_b] = part_extents(b, u);
  const double tan_a = std::sqrt(std::max(a_a * a_a / (b_a * b_a) - 1, 0.0));
  const double tan_b = std::sqrt(std::max(a_b * a_b / (b_b * b_b) - 1, 0.0));
  r.allowed = params.c_size * 0.5 * (a_a + a_b) + params.c_tilt * h * 0.5 * (tan_a + tan_b);
  r.ok = r.distance <= r.allowed;
  return r;
}

std::vector<TrackEdge> candidate_edges(const TrackParts& lo, const TrackParts& hi, double h, const TrackParams& params) {
  const std::size_t na = lo.parts.size(), nb = hi.parts.size();
  std::vector<TrackEdge> edges;
  if (na == 0 || nb == 0) return edges;
  std::unordered_map<std::int64_t, long> overlap;  // a * nb + b -> pixels in both
  for (std::size_t i = 0; i < lo.labels.size(); ++i) {
    const int a = lo.labels.data[i], b = hi.labels.data[i];
    if (a >= 0 && b >= 0) ++overlap[std::int64_t(a) * std::int64_t(nb) + b];
  }
  std::vector<char> has_a(na, 0), has_b(nb, 0);
  for (const auto& [key, pixels] : overlap) {
    const int a = int(key / std::int64_t(nb)), b = int(key % std::int64_t(nb));
    has_a[std::size_t(a)] = has_b[std::size_t(b)] = 1;
    edges.push_back({a, b, hi.parts[std::size_t(b)].centroid - lo.parts[std::size_t(a)].centroid, false, pixels});
  }
  // Bridge candidates: pairs with a part that overlaps nothing, kept if the
  // best (least distance / allowed) of their lower or of their upper part.
  struct Candidate {
    int a, b;
    double q;
  };
  std::vector<Candidate> cand;
  constexpr double kNone = std::numeric_limits<double>::infinity();
  std::vector<double> best_a(na, kNone), best_b(nb, kNone);
  for (std::size_t a = 0; a < na; ++a)
    for (std::size_t b = 0; b < nb; ++b) {
      if (has_a[a] && has_b[b]) continue;
      if (overlap.count(std::int64_t(a) * std::int64_t(nb) + std::int64_t(b))) continue;
      const BridgeTest t = bridge_test(lo.parts[a], hi.parts[b], h, params);
      if (!t.ok) continue;
      const double q = t.allowed > 0 ? t.distance / t.allowed : 0.0;
      cand.push_back({int(a), int(b), q});
      best_a[a] = std::min(best_a[a], q), best_b[b] = std::min(best_b[b], q);
    }
  for (const Candidate& c : cand)
    if (c.q == best_a[std::size_t(c.a)] || c.q == best_b[std::size_t(c.b)])
      edges.push_back({c.a, c.b, hi.parts[std::size_t(c.b)].centroid - lo.parts[std::size_t(c.a)].centroid, true, 0});
  std::sort(edges.begin(), edges.end(), [](const TrackEdge& x, const TrackEdge& y) {
    return x.a != y.a ? x.a < y.a : x.b < y.b;
  });
  return edges;
}

long drop_unsupported_bridges(std::vector<TrackEdge>& edges, const std::vector<TrackEdge>* below,
                              const std::vector<TrackEdge>* above, double c_vel) {
  auto continues = [&](const TrackEdge& e, const TrackEdge& f) {
    return (f.shift - e.shift).norm() <= c_vel * std::max(f.shift.norm(), e.shift.norm());
  };
  auto supported = [&](const TrackEdge& e) {
    if (below)
      for (const TrackEdge& f : *below)
        if (f.b == e.a && continues(e, f)) return true;
    if (above)
      for (const TrackEdge& f : *above)
        if (f.a == e.b && continues(e, f)) return true;
    return false;
  };
  const auto end = std::remove_if(edges.begin(), edges.end(), [&](const TrackEdge& e) { return e.bridge && !supported(e); });
  const long dropped = long(edges.end() - end);
  edges.erase(end, edges.end());
  return dropped;
}

TrackMotionStep edge_motion(const TrackEdge& e, const std::vector<TrackEdge>& edges, const TrackPart& a,
                            const TrackPart& b, const TrackParams& params) {
  if (!e.bridge) {
    const auto out = std::count_if(edges.begin(), edges.end(), [&](const TrackEdge& f) { return f.a == e.a; });
    const auto in = std::count_if(edges.begin(), edges.end(), [&](const TrackEdge& f) { return f.b == e.b; });
    const bool one_to_one = out == 1 && in == 1;
    switch (params.motion) {
      case TrackMotion::RuleOnly: return {};
      case TrackMotion::Gated: {
        const double iou = double(e.overlap) / double(a.pixels + b.pixels - e.overlap);
        if (!one_to_one || iou > params.iou_max) return {};
        break;
      }
      case TrackMotion::Auto:
        if (!one_to_one || double(std::max(a.pixels, b.pixels)) > params.similar_area * double(std::min(a.pixels, b.pixels)))
          return {};
        break;
    }
  }
  TrackMotionStep m{e.shift.x(), e.shift.y(), 0.0};
  if (std::min(a.anisotropy, b.anisotropy) >= params.rotate_min_anisotropy) {
    // Axes are lines: the turn between them lies in [-90, 90) deg.
    const double turn = std::fmod(b.angle - a.angle + M_PI / 2, M_PI);
    m.da = (turn < 0 ? turn + M_PI : turn) - M_PI / 2;
  }
  return m;
}

}  // namespace isoloft::detail
