#include "isoloft/field/marching.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <queue>
#include <string>
#include <utility>

#include "isoloft/core/error.h"
#include "isoloft/field/edt.h"
#include "isoloft/field/fast_sweeping.h"

namespace isoloft {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kDx8[8] = {-1, 1, 0, 0, -1, 1, -1, 1};
constexpr int kDy8[8] = {0, 0, -1, 1, -1, -1, 1, 1};

using detail::kFar;
using detail::kKnown;
using detail::kTrial;

// Offer the value of the just-known pixel i to its 8 neighbours that are not
// known; `touched(q)` is called for every neighbour whose value dropped.
// ClosestPoint: q takes segment(i) if it is nearer than q's current one.
// Eikonal: q is recomputed from its known neighbours.
template <class Touched>
void offer(detail::ExtendState& s, const std::vector<std::uint8_t>& status, int i, ExtendUpdate update,
           Touched&& touched) {
  const int x = i % s.width, y = i / s.width;
  const bool interior = x > 0 && y > 0 && x + 1 < s.width && y + 1 < s.height;
  if (update == ExtendUpdate::ClosestPoint) {
    const std::int32_t si = s.seg[i];
    const detail::SegmentGeom g = s.geom[std::size_t(si)];  // a copy: the writes below cannot alias it
    for (int k = 0; k < 8; ++k) {
      const int qx = x + kDx8[k], qy = y + kDy8[k];
      if (!interior && (qx < 0 || qy < 0 || qx >= s.width || qy >= s.height)) continue;
      const int q = qy * s.width + qx;
      if (status[q] == kKnown || s.seg[q] == si) continue;
      const double c2 = detail::segment_distance2(g, qx, qy);
      if (c2 < s.value[q]) {
        s.value[q] = c2;
        s.seg[q] = si;
        touched(q);
      }
    }
    return;
  }
  for (int k = 0; k < 8; ++k) {
    const int qx = x + kDx8[k], qy = y + kDy8[k];
    if (!interior && (qx < 0 || qy < 0 || qx >= s.width || qy >= s.height)) continue;
    const int q = qy * s.width + qx;
    if (status[q] == kKnown) continue;
    const double u = detail::eikonal_update(s, qx, qy, status.data());
    if (u < s.value[q]) {
      s.value[q] = u;
      touched(q);
    }
  }
}

// A pixel becomes known: ClosestPoint refines its segment by walking along
// the curve (once per pixel, not on every tentative update).
void settle(detail::ExtendState& s, int i, ExtendUpdate update) {
  if (update != ExtendUpdate::ClosestPoint) return;
  s.seg[i] = detail::descend_along_curve(s, i % s.width, i / s.width, s.seg[i], s.value[i]);
}

std::vector<std::uint8_t> initial_status(const detail::ExtendState& s) {
  std::vector<std::uint8_t> status(s.value.size(), kFar);
  for (std::size_t i = 0; i < status.size(); ++i)
    if (s.fixed[i]) status[i] = kKnown;
  return status;
}

// The band's grids and links agree. \throw ParamError if not.
void check_band(const NarrowBandResult& band) {
  const int w = band.distance.width, h = band.distance.height;
  auto same = [&](int gw, int gh) { return gw == w && gh == h; };
  if (!same(band.known.width, band.known.height) || !same(band.inside.width, band.inside.height) ||
      !same(band.nearest_segment.width, band.nearest_segment.height))
    throw ParamError("distance extension: narrow-band grids differ in size (distance " + std::to_string(w) + "x" +
                     std::to_string(h) + ")");
  if (band.links.size() != band.segments.size())
    throw ParamError("distance extension: " + std::to_string(band.links.size()) + " segment links for " +
                     std::to_string(band.segments.size()) + " segments");
}

// Known band pixel i's nearest segment. \throw ParamError if invalid.
std::int32_t band_segment(const NarrowBandResult& band, std::size_t i) {
  const std::int32_t k = band.nearest_segment.data[i];
  if (k < 0 || std::size_t(k) >= band.segments.size())
    throw ParamError("distance extension: known band pixel " + std::to_string(i) + " has no valid segment");
  return k;
}

std::vector<detail::SegmentGeom> segment_geoms(const NarrowBandResult& band) {
  std::vector<detail::SegmentGeom> geom;
  geom.reserve(band.segments.size());
  for (const Segment2d& sg : band.segments) {
    const Vec2d d = sg[1] - sg[0];
    const double len2 = d.squaredNorm();
    geom.push_back({sg[0].x(), sg[0].y(), d.x(), d.y(), len2 > 0.0 ? 1.0 / len2 : 0.0});
  }
  return geom;
}

// \throw ParamError if the required-pixel mask (if any) is not w x h.
void check_required(const Grid2u8* required, int w, int h) {
  if (required && (required->width != w || required->height != h))
    throw ParamError("distance extension: the required-pixel mask is " + std::to_string(required->width) + "x" +
                     std::to_string(required->height) + ", the grid " + std::to_string(w) + "x" + std::to_string(h));
}

// Required pixels not known yet: a march may stop when none is left.
class RequiredLeft {
 public:
  RequiredLeft(const Grid2u8* required, const std::vector<std::uint8_t>& status, int width, int height) : required_(required) {
    if (!required) return;
    check_required(required, width, height);
    for (std::size_t i = 0; i < status.size(); ++i) left_ += required->data[i] && status[i] != kKnown;
  }
  void known(int i) { left_ -= required_ && required_->data[std::size_t(i)]; }
  [[nodiscard]] bool done() const { return required_ && left_ == 0; }

 private:
  const Grid2u8* required_;
  long left_ = 0;
};

}  // namespace

namespace detail {

ExtendState init_extend_state(const NarrowBandResult& band, ExtendUpdate update) {
  check_band(band);
  const int w = band.distance.width, h = band.distance.height;
  ExtendState s;
  s.width = w;
  s.height = h;
  s.value.assign(band.distance.size(), kInf);
  s.fixed.assign(band.distance.size(), 0);
  if (update == ExtendUpdate::ClosestPoint) s.geom = segment_geoms(band);
  s.links = &band.links;
  if (update == ExtendUpdate::ClosestPoint) s.seg.assign(band.distance.size(), -1);
  for (std::size_t i = 0; i < s.value.size(); ++i) {
    if (!band.known.data[i]) continue;
    s.fixed[i] = 1;
    if (update == ExtendUpdate::ClosestPoint) {
      const std::int32_t k = band_segment(band, i);
      const int x = int(i % std::size_t(w)), y = int(i / std::size_t(w));
      s.seg[i] = k;
      s.value[i] = segment_distance2(s, x, y, k);
    } else {
      s.value[i] = std::abs(double(band.distance.data[i]));
    }
  }
  return s;
}

std::int32_t descend_along_curve(const std::vector<SegmentGeom>& geom,
                                 const std::vector<std::array<std::int32_t, 2>>& links, int x, int y, std::int32_t k,
                                 double& d2) {
  // Follow the curve both ways from k, up to kWalkSteps segments each, while
  // the distance stays within kWalkSlack of the best so far: the chord
  // polyline's distance wiggles (by <= L^2 / (8 R), 0.008 px at R = 3) and has
  // flat spots (zero-length pieces where the curve passes through a pixel
  // centre), which would stop a strict descent.
  constexpr double kWalkSlack = 0.01;  // px
  constexpr int kWalkSteps = 32;       // segments each way
  std::int32_t best = k;
  double bd = d2;
  double limit = (std::sqrt(bd) + kWalkSlack) * (std::sqrt(bd) + kWalkSlack);
  for (int e = 0; e < 2; ++e) {
    std::int32_t prev = k, cur = links[std::size_t(k)][e];
    for (int step = 0; cur >= 0 && cur != k && step < kWalkSteps; ++step) {
      const double dc = segment_distance2(geom[std::size_t(cur)], x, y);
      if (dc > limit) break;
      if (dc < bd) {
        bd = dc;
        best = cur;
        limit = (std::sqrt(bd) + kWalkSlack) * (std::sqrt(bd) + kWalkSlack);
      }
      const auto& l = links[std::size_t(cur)];
      const std::int32_t next = l[0] == prev ? l[1] : l[0];
      prev = cur;
      cur = next;
    }
  }
  d2 = bd;
  return best;
}

double eikonal_update(const ExtendState& s, int x, int y, const std::uint8_t* status) {
  constexpr double kSqrt2 = 1.41421356237309504880;
  auto v = [&](int qx, int qy) {
    if (qx < 0 || qy < 0 || qx >= s.width || qy >= s.height) return kInf;
    const std::size_t q = std::size_t(qy) * s.width + qx;
    if (status && status[q] != kKnown) return kInf;
    return s.value[q];
  };
  const double ax[2] = {v(x - 1, y), v(x + 1, y)};  // adjacent, x side
  const double ay[2] = {v(x, y - 1), v(x, y + 1)};  // adjacent, y side
  double u = std::min({ax[0], ax[1], ay[0], ay[1]}) + 1.0;
  // Triangle (adjacent a, diagonal c): the path enters through the edge a-c at
  // t in [0, 1] from a; interior optimum when 0 < a - c < 1/sqrt(2).
  auto tri = [&](double a, double c) {
    const double sd = a - c;
    if (sd > 0.0 && sd < detail::kCorrectnessDelta) u = std::min(u, a + std::sqrt(1.0 - sd * sd));
  };
  for (int sy = 0; sy < 2; ++sy) {
    for (int sx = 0; sx < 2; ++sx) {
      const double c = v(x + (sx ? 1 : -1), y + (sy ? 1 : -1));
      if (c == kInf) continue;
      u = std::min(u, c + kSqrt2);
      if (ax[sx] != kInf) tri(ax[sx], c);
      if (ay[sy] != kInf) tri(ay[sy], c);
    }
  }
  return u;
}

Grid2f finish_extend(const NarrowBandResult& band, const ExtendState& s, ExtendUpdate update) {
  Grid2f out(s.width, s.height);
  const bool any = std::any_of(s.fixed.begin(), s.fixed.end(), [](std::uint8_t f) { return f != 0; });
  for (std::size_t i = 0; i < out.size(); ++i) {
    const float sign = band.inside.data[i] ? 1.0f : -1.0f;
    if (s.fixed[i]) {
      out.data[i] = band.distance.data[i];
    } else if (!any || !std::isfinite(s.value[i])) {
      out.data[i] = sign * kNoSurfaceDistance;
    } else {
      const double d = update == ExtendUpdate::ClosestPoint ? std::sqrt(s.value[i]) : s.value[i];
      out.data[i] = sign * float(d);
    }
  }
  return out;
}

}  // namespace detail

Grid2f extend_fast_marching(const NarrowBandResult& band, ExtendUpdate update, const Grid2u8* required) {
  detail::ExtendState s = detail::init_extend_state(band, update);
  std::vector<std::uint8_t> status = initial_status(s);
  RequiredLeft left(required, status, s.width, s.height);
  using Entry = std::pair<double, int>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> heap;
  // Lazy deletion: a pixel is pushed each time its value drops; stale entries
  // (value no longer matching, or already known) are skipped when popped.
  auto push = [&](int q) {
    status[q] = kTrial;
    heap.emplace(s.value[q], q);
  };
  for (int i = 0; i < int(status.size()); ++i)
    if (status[i] == kKnown) offer(s, status, i, update, push);
  while (!heap.empty() && !left.done()) {
    const auto [v, i] = heap.top();
    heap.pop();
    if (status[i] == kKnown || v != s.value[i]) continue;
    status[i] = kKnown;
    left.known(i);
    settle(s, i, update);
    offer(s, status, i, update, push);
  }
  return detail::finish_extend(band, s, update);
}

Grid2f detail::marching_cc_generic(const NarrowBandResult& band, ExtendUpdate update, const Grid2u8* required) {
  detail::ExtendState s = detail::init_extend_state(band, update);
  std::vector<std::uint8_t> status = initial_status(s);
  RequiredLeft left(required, status, s.width, s.height);
  std::vector<int> trial, newly;
  auto add = [&](int q) {
    if (status[q] == kFar) {
      status[q] = kTrial;
      trial.push_back(q);
    }
  };
  for (int i = 0; i < int(status.size()); ++i)
    if (status[i] == kKnown) offer(s, status, i, update, add);
  const bool squared = update == ExtendUpdate::ClosestPoint;
  while (!trial.empty() && !left.done()) {
    double m = kInf;
    for (int i : trial) m = std::min(m, s.value[i]);
    // Every trial value <= min + delta is final: any later update comes from a
    // pixel known with value >= min and adds at least delta.
    const double threshold =
        squared ? (std::sqrt(m) + detail::kCorrectnessDelta) * (std::sqrt(m) + detail::kCorrectnessDelta)
                : m + detail::kCorrectnessDelta;
    newly.clear();
    std::size_t keep = 0;
    for (int i : trial) {
      if (s.value[i] <= threshold) {
        newly.push_back(i);
        status[i] = kKnown;
        left.known(i);
      } else {
        trial[keep++] = i;
      }
    }
    trial.resize(keep);
    for (int i : newly) settle(s, i, update);
    for (int i : newly) offer(s, status, i, update, add);
  }
  return detail::finish_extend(band, s, update);
}


namespace {

// One pixel of the closest-point march, its fields side by side (one cache
// line holds a pixel's and its row neighbours' state).
struct MarchCell {
  double value;        // squared distance, +inf unknown
  std::int32_t seg;    // nearest segment, -1 unknown
  std::uint8_t status; // kFar, kTrial, kKnown
  std::uint8_t required;
  std::uint8_t inside; // band.inside: the output's sign
};

// Pixels ahead in the settle-and-offer pass whose 3x3 cells are prefetched:
// enough to cover a miss (~100 ns) at ~20 ns a pixel.
constexpr std::size_t kPrefetchAhead = 8;

// extend_marching_cc with ClosestPoint: marching_cc_generic's march, the same
// offers in the same order, over a grid padded by one known pixel on every
// side (no bounds checks) with each pixel's state in one MarchCell. One pass
// over the grid makes the cells and the output of band and far pixels; a
// marched pixel's output is written when it is settled (its value is final
// then), or at the end if it is still a trial one.
Grid2f marching_cc_closest(const NarrowBandResult& band, const Grid2u8* required) {
  check_band(band);
  const int w = band.distance.width, h = band.distance.height;
  check_required(required, w, h);
  const std::vector<detail::SegmentGeom> geom = segment_geoms(band);
  const int pw = w + 2;
  // Not value-initialised: the pass below writes every cell once.
  const std::unique_ptr<MarchCell[]> cells(new MarchCell[std::size_t(pw) * std::size_t(h + 2)]);
  MarchCell* const cell = cells.get();
  auto at = [pw](int x, int y) { return (y + 1) * pw + x + 1; };
  const MarchCell pad{kInf, -1, kKnown, 0, 0};
  std::fill(cell, cell + pw, pad);
  std::fill(cell + std::size_t(at(-1, h)), cell + std::size_t(at(-1, h)) + std::size_t(pw), pad);
  long left = 0;  // required pixels not known yet
  Grid2f out(w, h);
  float* const o = out.data.data();
  // Raw pointers: the cells' byte stores may alias a vector's own pointer,
  // which would be loaded again on every pixel.
  const std::uint8_t* known = band.known.data.data();
  const std::uint8_t* needed = required ? required->data.data() : nullptr;
  const std::uint8_t* inside = band.inside.data.data();
  const float* given = band.distance.data.data();
  for (int y = 0; y < h; ++y) {
    MarchCell* row = cell + std::size_t(at(0, y));
    row[-1] = pad;
    row[w] = pad;
    for (int x = 0; x < w; ++x) {
      const std::size_t i = std::size_t(y) * std::size_t(w) + std::size_t(x);
      MarchCell& c = row[x];
      c.required = needed && needed[i];
      c.inside = inside[i];
      if (!known[i]) {
        c.value = kInf;
        c.seg = -1;
        c.status = kFar;
        left += c.required;
        o[i] = (inside[i] ? 1.0f : -1.0f) * kNoSurfaceDistance;
        continue;
      }
      const std::int32_t k = band_segment(band, i);
      c.seg = k;
      c.value = detail::segment_distance2(geom[std::size_t(k)], x, y);
      c.status = kKnown;
      o[i] = given[i];
    }
  }
  // A marched pixel's output: its value is final (settled) or the march stopped.
  auto output = [&](int p, int x, int y) {
    const MarchCell& c = cell[std::size_t(p)];
    o[std::size_t(y) * std::size_t(w) + std::size_t(x)] = (c.inside ? 1.0f : -1.0f) * float(std::sqrt(c.value));
  };
  const int off[8] = {-1, 1, -pw, pw, -pw - 1, -pw + 1, pw - 1, pw + 1};  // kDx8 / kDy8's order
  std::vector<int> trial, newly;
  // The least value written since `lowest` was reset: every pixel written is
  // a trial one until the next round, and values only drop, so after a
  // round's split and offers it is the least trial value (the round's min,
  // without a pass over the trial list).
  double lowest = kInf;
  auto offer_from = [&](int p, int x, int y) {
    const std::int32_t si = cell[std::size_t(p)].seg;
    const detail::SegmentGeom g = geom[std::size_t(si)];
    for (int k = 0; k < 8; ++k) {
      MarchCell& c = cell[std::size_t(p + off[k])];
      if (c.status == kKnown || c.seg == si) continue;
      const double c2 = detail::segment_distance2(g, x + kDx8[k], y + kDy8[k]);
      if (c2 < c.value) {
        c.value = c2;
        c.seg = si;
        lowest = std::min(lowest, c2);
        if (c.status == kFar) {
          c.status = kTrial;
          trial.push_back(p + off[k]);
        }
      }
    }
  };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (known[std::size_t(y) * std::size_t(w) + std::size_t(x)]) offer_from(at(x, y), x, y);
  while (!trial.empty() && !(required && left == 0)) {
    const double m = lowest;
    const double threshold = (std::sqrt(m) + detail::kCorrectnessDelta) * (std::sqrt(m) + detail::kCorrectnessDelta);
    lowest = kInf;
    newly.clear();
    std::size_t keep = 0;
    for (int p : trial) {
      MarchCell& c = cell[std::size_t(p)];
      if (c.value <= threshold) {
        newly.push_back(p);
        c.status = kKnown;
        left -= c.required;
      } else {
        lowest = std::min(lowest, c.value);
        trial[keep++] = p;
      }
    }
    trial.resize(keep);
    // Settling p and offering from it in one pass is the two-pass order's
    // result: offers write only pixels not known, settling reads only known
    // ones. The prefetch hides the scattered pixels' cache misses.
    for (std::size_t j = 0; j < newly.size(); ++j) {
      if (j + kPrefetchAhead < newly.size()) {
        const int q = newly[j + kPrefetchAhead];
        for (int r : {q - pw, q, q + pw}) {
          __builtin_prefetch(&cell[std::size_t(r - 1)], 1);
          __builtin_prefetch(&cell[std::size_t(r + 1)], 1);
        }
      }
      const int p = newly[j];
      const int x = p % pw - 1, y = p / pw - 1;
      MarchCell& c = cell[std::size_t(p)];
      c.seg = detail::descend_along_curve(geom, band.links, x, y, c.seg, c.value);
      output(p, x, y);
      offer_from(p, x, y);
    }
  }
  for (int p : trial) output(p, p % pw - 1, p / pw - 1);
  return out;
}

}  // namespace

Grid2f extend_marching_cc(const NarrowBandResult& band, ExtendUpdate update, const Grid2u8* required) {
  return update == ExtendUpdate::ClosestPoint ? marching_cc_closest(band, required)
                                              : detail::marching_cc_generic(band, update, required);
}

Grid2f extend_distance(const NarrowBandResult& band, const ExtendParams& params, const Grid2u8* required) {
  params_table<ExtendParams>().validate(params);
  switch (params.method) {
    case ExtendMethod::FastMarching: return extend_fast_marching(band, params.update, required);
    case ExtendMethod::MarchingCorrectness: return extend_marching_cc(band, params.update, required);
    case ExtendMethod::FastSweeping: return extend_fast_sweeping(band, params.update, params.max_sweep_cycles);
  }
  throw ParamError("distance extension: unknown method");
}

}  // namespace isoloft
