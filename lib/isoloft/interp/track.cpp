// The track z scheme (interp/track.h): knots in, parts matched, pieces along
// the trajectories, planes out.
#include "isoloft/interp/track.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>

#include "isoloft/core/error.h"
#include "isoloft/field/edt.h"
#include "isoloft/interp/track_graph.h"

namespace isoloft {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// A part's own field is kept this far beyond its shell (px): a moving
// piece reads it there; farther out, the distance to the part's box.
constexpr int kPartFieldMargin = 4;
// A piece covers its parts' shells along the trajectory plus this (px):
// every Marching Cubes corner beside its surface.
constexpr int kPieceMargin = 2;
// Trajectory samples for a moving piece's extent (the box between two
// samples moves by at most 1/16 of the pair's shift).
constexpr int kExtentSamples = 16;
// Least turn taken as a screw (rad): its fixed point is well conditioned.
constexpr double kMinScrewTurn = 1e-3;
// Most knots a trajectory reads on each side of its interval: the tangent
// reach of the monotone and extremum-preserving rules (interp/z_stream.h).
constexpr std::size_t kChainReach = 2;

using Pose = std::array<double, 3>;  // shift x, y (px) and turn (rad) of a frame from the trajectory's origin

PixelBox grown(PixelBox b, int by, int w, int h) {
  return {std::max(0, b.x0 - by), std::max(0, b.y0 - by), std::min(w, b.x1 + by), std::min(h, b.y1 + by)};
}

PixelBox joined(const PixelBox& a, const PixelBox& b) {
  if (a.empty()) return b;
  if (b.empty()) return a;
  return {std::min(a.x0, b.x0), std::min(a.y0, b.y0), std::max(a.x1, b.x1), std::max(a.y1, b.y1)};
}

}  // namespace

// One knot: its field, parts, each part's own field, and the matches to the next knot.
struct TrackStream::Knot {
  double z = 0;
  Grid2f field;
  bool clamped = false;  // has parts: the background reads min(field, iso - kTrackShell)
  detail::TrackParts parts;
  struct PartField {
    PixelBox box;   // where `values` hold; empty values: the knot's field is the part's (one part)
    Grid2f values;  // the field on the pixels the part owns, else min(field, 0.5 - distance to the part)
  };
  std::vector<PartField> part_fields;
  std::vector<detail::TrackEdge> candidates;  // to the next knot, before chain support
  std::vector<detail::TrackEdge> edges;       // to the next knot
  std::vector<detail::TrackMotionStep> motion;  // per edge
  bool edges_done = false;
  long counted = 0;

  // The value of part `part` (-1: the virtual knot min(field, iso)) at
  // pixel (x, y), which may lie outside the grid.
  [[nodiscard]] float tap(int part, int x, int y, float iso) const {
    const int cx = std::clamp(x, 0, field.width - 1), cy = std::clamp(y, 0, field.height - 1);
    const float f = field(cx, cy);
    if (part < 0) return std::min(f, iso);
    const PartField& pf = part_fields[std::size_t(part)];
    if (pf.values.empty()) return f;
    const PixelBox& b = pf.box;
    if (x >= b.x0 && x < b.x1 && y >= b.y0 && y < b.y1) return pf.values(x - b.x0, y - b.y0);
    const PixelBox& p = parts.parts[std::size_t(part)].box;
    const double dx = std::max({p.x0 - x, 0, x - (p.x1 - 1)}), dy = std::max({p.y0 - y, 0, y - (p.y1 - 1)});
    return std::min(f, float(0.5 - std::sqrt(dx * dx + dy * dy)));
  }

  // Bilinear in the taps; exact (no blend) at a whole pixel.
  [[nodiscard]] double sample(int part, double x, double y, float iso) const {
    const double fx0 = std::floor(x), fy0 = std::floor(y);
    const int ix = int(fx0), iy = int(fy0);
    const double fx = x - fx0, fy = y - fy0;
    auto row = [&](int yy) {
      const double a = tap(part, ix, yy, iso);
      return fx == 0 ? a : a + fx * (double(tap(part, ix + 1, yy, iso)) - a);
    };
    const double lo = row(iy);
    return fy == 0 ? lo : lo + fy * (row(iy + 1) - lo);
  }
};

// A knot of a trajectory: a part (or a virtual knot) and its frame.
struct ChainKnot {
  const TrackStream::Knot* knot = nullptr;
  int part = -1;  // -1: virtual, min(field, iso), carrying no motion
  double z = 0;
  Pose pose{0, 0, 0};
};

// One piece: a trajectory through up to six knots, chain[i0] and chain[i0 + 1] its interval's.
struct TrackStream::Piece {
  std::vector<ChainKnot> chain;
  std::size_t i0 = 0;
  Vec2d centre{0, 0};  // the trajectory's origin: the centroid of its first real end part
  PixelBox region;
  bool moving = false;
  double screw_min = 0;  // rad
  Grid2f f0, f1, m0, m1;  // a piece that does not move: knot values and tangents over `region`

  [[nodiscard]] const ChainKnot& lo() const { return chain[i0]; }
  [[nodiscard]] const ChainKnot& hi() const { return chain[i0 + 1]; }

  // The trajectory's frame at fraction t of the interval: on a screw (an
  // arc about the fixed point of the pair's rigid motion) if it turns by
  // more than screw_min, else a Hermite path whose tangents are the
  // Catmull-Rom ones through the chained frames (a virtual knot bends nothing).
  [[nodiscard]] Pose path(double t) const {
    const Pose &p0 = lo().pose, &p1 = hi().pose;
    if (t == 0) return p0;
    if (t == 1) return p1;
    const double da = p1[2] - p0[2];
    if (std::abs(da) > std::max(screw_min, kMinScrewTurn)) {
      const double c = std::cos(da), s = std::sin(da);
      // The fixed point o of x -> R (x - p0) + p1: (I - R) o = p1 - R p0.
      const double rx = p1[0] - (c * p0[0] - s * p0[1]), ry = p1[1] - (s * p0[0] + c * p0[1]);
      const double a = 1 - c, b = s, det = a * a + b * b;  // I - R = [[a, b], [-b, a]]
      const double ox = (a * rx - b * ry) / det, oy = (b * rx + a * ry) / det;
      const double ct = std::cos(t * da), st = std::sin(t * da);
      const double qx = p0[0] - ox, qy = p0[1] - oy;
      return {ox + ct * qx - st * qy, oy + st * qx + ct * qy, p0[2] + t * da};
    }
    const double h = hi().z - lo().z;
    const bool has_m = i0 > 0 && chain[i0 - 1].part >= 0, has_p = i0 + 2 < chain.size() && chain[i0 + 2].part >= 0;
    const double t2 = t * t, t3 = t2 * t;
    const double h00 = 2 * t3 - 3 * t2 + 1, h10 = (t3 - 2 * t2 + t) * h, h01 = -2 * t3 + 3 * t2, h11 = (t3 - t2) * h;
    Pose out;
    for (int c = 0; c < 3; ++c) {
      const double m0 = has_m ? (p1[c] - chain[i0 - 1].pose[c]) / (hi().z - chain[i0 - 1].z) : (p1[c] - p0[c]) / h;
      const double m1 = has_p ? (chain[i0 + 2].pose[c] - p0[c]) / (chain[i0 + 2].z - lo().z) : (p1[c] - p0[c]) / h;
      out[std::size_t(c)] = h00 * p0[c] + h10 * m0 + h01 * p1[c] + h11 * m1;
    }
    return out;
  }

  // Where knot c's frame sees the output pixels when the trajectory is at
  // pt: pixel p maps to p + shift + (R - I)(p - centre - pt), R the turn.
  struct View {
    double shift_x = 0, shift_y = 0, cos_1 = 0, sin = 0, ox = 0, oy = 0;  // cos - 1: exact 0 without a turn
    [[nodiscard]] Vec2d at(int px, int py) const {
      const double qx = px - ox, qy = py - oy;
      return {px + shift_x + (cos_1 * qx - sin * qy), py + shift_y + (sin * qx + cos_1 * qy)};
    }
  };
  [[nodiscard]] View view(const ChainKnot& c, const Pose& pt) const {
    const double da = c.pose[2] - pt[2];
    return {c.pose[0] - pt[0], c.pose[1] - pt[1], da != 0 ? std::cos(da) - 1 : 0.0, da != 0 ? std::sin(da) : 0.0,
            centre.x() + pt[0], centre.y() + pt[1]};
  }

  // Output position of knot c's point (x, y) when the trajectory is at pt.
  [[nodiscard]] Vec2d placed(const ChainKnot& c, const Pose& pt, double x, double y) const {
    const double da = pt[2] - c.pose[2], cs = std::cos(da), sn = std::sin(da);
    const double qx = x - centre.x() - c.pose[0], qy = y - centre.y() - c.pose[1];
    return {centre.x() + pt[0] + cs * qx - sn * qy, centre.y() + pt[1] + sn * qx + cs * qy};
  }
};

struct TrackStream::Interval {
  std::size_t k = 0;
  const Knot* lo = nullptr;
  const Knot* hi = nullptr;
  std::vector<Piece> pieces;
  long counted = 0;
};

TrackStream::TrackStream(std::vector<double> z, const TrackParams& params, SplineKind kind, float iso, int width,
                         int height, ZStream::NextKnot next, ResidentCount* count)
    : z_(std::move(z)), params_(params), kind_(kind), iso_(iso), width_(width), height_(height), next_(std::move(next)),
      count_(count) {
  if (z_.size() < 2) throw ParamError("track: needs at least 2 knots");
  for (std::size_t i = 1; i < z_.size(); ++i)
    if (!(z_[i] > z_[i - 1])) throw ParamError("track: knots must be strictly increasing (z[" + std::to_string(i) + "])");
  if (width < 1 || height < 1) throw ParamError("track: empty fields");
  params_table<TrackParams>().validate(params_);
}

TrackStream::~TrackStream() { count(-counted_); }

void TrackStream::count(long delta) {
  counted_ += delta;
  if (count_) count_->change(delta);
}

std::size_t TrackStream::interval(double q) const { return knot_interval(z_, q); }

TrackStream::Knot& TrackStream::knot(std::size_t j) {
  if (j < first_ || j >= first_ + knots_.size()) throw Error("track: knot " + std::to_string(j) + " is not held");
  return *knots_[j - first_];
}

// Pulls the next knot: its parts and their fields; the candidates to it,
// and the matches of the interval two below (whose chain support it decides).
void TrackStream::pull() {
  const std::size_t j = first_ + knots_.size();
  auto pulled_at = Clock::now();
  Grid2f f = next_();
  setup_seconds_ -= seconds_since(pulled_at);  // reach() counts the rest
  if (f.width != width_ || f.height != height_)
    throw ParamError("track: knot " + std::to_string(j) + " is " + std::to_string(f.width) + "x" +
                     std::to_string(f.height) + ", expected " + std::to_string(width_) + "x" + std::to_string(height_));
  auto kn = std::make_unique<Knot>();
  kn->z = z_[j];
  kn->field = std::move(f);
  kn->parts = detail::track_parts(kn->field, iso_);
  const std::size_t n = kn->parts.parts.size();
  kn->clamped = n > 0;
  kn->part_fields.resize(n);
  long part_pixels = 0;
  if (n > 1) {
    // Each part's field: the knot's where the part is the nearest, else
    // no more than 0.5 - the distance to the part (still <= the knot's).
    for (std::size_t a = 0; a < n; ++a) {
      const detail::TrackPart& p = kn->parts.parts[a];
      Knot::PartField& pf = kn->part_fields[a];
      pf.box = grown(joined(p.shell, p.box), kPartFieldMargin, width_, height_);
      Grid2u8 mine(pf.box.width(), pf.box.height());
      for (int y = 0; y < mine.height; ++y)
        for (int x = 0; x < mine.width; ++x) mine(x, y) = kn->parts.labels(pf.box.x0 + x, pf.box.y0 + y) == int(a);
      const Grid2f sq = squared_edt(mine);
      pf.values = Grid2f(mine.width, mine.height);
      for (int y = 0; y < mine.height; ++y)
        for (int x = 0; x < mine.width; ++x) {
          const int gx = pf.box.x0 + x, gy = pf.box.y0 + y;
          const float d = kn->field(gx, gy);
          pf.values(x, y) = kn->parts.owner(gx, gy) == int(a) ? d : std::min(d, float(0.5 - std::sqrt(double(sq(x, y)))));
        }
      part_pixels += long(pf.values.size());
    }
    kn->parts.owner = Grid2i();
  }
  // Resident: the field, the labels (until the next knot's candidates), the part fields.
  const long pixels = long(width_) * long(height_);
  kn->counted = 2 + (part_pixels + pixels - 1) / pixels;
  count(kn->counted);
  knots_.push_back(std::move(kn));

  auto finish_edges = [&](std::size_t i) {  // interval i's matches, once the candidates beside it are known
    Knot& a = knot(i);
    const std::vector<detail::TrackEdge>* below = i > 0 ? &knot(i - 1).candidates : nullptr;
    const std::vector<detail::TrackEdge>* above = i + 2 < z_.size() ? &knot(i + 1).candidates : nullptr;
    a.edges = a.candidates;
    if (params_.chain_support) stats_.bridges_dropped += detail::drop_unsupported_bridges(a.edges, below, above, params_.c_vel);
    const Knot& b = knot(i + 1);
    for (const detail::TrackEdge& e : a.edges) {
      a.motion.push_back(detail::edge_motion(e, a.edges, a.parts.parts[std::size_t(e.a)], b.parts.parts[std::size_t(e.b)], params_));
      (e.bridge ? stats_.bridges : stats_.overlaps) += 1;
    }
    a.edges_done = true;
  };
  if (j >= 1) {
    Knot& lo = knot(j - 1);
    lo.candidates = detail::candidate_edges(lo.parts, knot(j).parts, z_[j] - z_[j - 1], params_);
    lo.parts.labels = Grid2i();
    lo.counted -= 1;
    count(-1);
  }
  if (j >= 2) finish_edges(j - 2);
  if (j + 1 == z_.size()) {
    finish_edges(j - 1);
    knot(j).parts.labels = Grid2i();
    knot(j).counted -= 1;
    count(-1);
  }
}

void TrackStream::reach(std::size_t k) {
  if (k > z_.size() - 2) throw ParamError("track: interval " + std::to_string(k) + " beyond the last knot");
  if (!intervals_.empty() && k < intervals_.back()->k) throw ParamError("track: interval " + std::to_string(k) + " was passed already");
  if (!intervals_.empty() && intervals_.back()->k == k) return;
  const auto t0 = Clock::now();
  // Matches of intervals k - 2 .. k + 2: knots up to k + 4.
  while (first_ + knots_.size() < std::min(z_.size(), k + 5)) pull();
  build(k);
  // Knots below k - kChainReach are no trajectory's any more.
  while (first_ + kChainReach < k && !knots_.empty()) {
    count(-knots_.front()->counted);
    knots_.pop_front();
    ++first_;
  }
  setup_seconds_ += seconds_since(t0);
}

const TrackStream::Interval* TrackStream::built(std::size_t k) const {
  for (const auto& in : intervals_)
    if (in->k == k) return in.get();
  return nullptr;
}

void TrackStream::build(std::size_t k) {
  auto in = std::make_unique<Interval>();
  in->k = k;
  in->lo = &knot(k);
  in->hi = &knot(k + 1);
  const double screw_min = params_.screw_min_angle * M_PI / 180.0;

  // Up to kChainReach knots beyond part `part` of knot j on side `dir`
  // (-1 below, +1 above), nearest first: through single matches; a part
  // matched to nothing goes on through the neighbour knots as virtual knots
  // (their fields below iso: the column's, without other parts); a fork or
  // merge stops the chain.
  auto extend = [&](std::size_t j, int part, Pose pose, int dir) {
    std::vector<ChainKnot> out;
    for (std::size_t step = 0; step < kChainReach; ++step) {
      if (dir < 0 ? j == 0 : j + 1 >= z_.size()) break;
      const Knot& from = knot(dir < 0 ? j - 1 : j);  // holds the matches of the interval crossed
      const Knot& next = knot(dir < 0 ? j - 1 : j + 1);
      if (!from.edges_done) throw Error("track: the matches below knot " + std::to_string(j) + " are not made");
      int found = -1, matches = 0;
      for (std::size_t i = 0; i < from.edges.size() && part >= 0; ++i)
        if ((dir < 0 ? from.edges[i].b : from.edges[i].a) == part) found = int(i), ++matches;
      if (matches > 1) break;
      if (matches == 0) {
        out.push_back({&next, -1, next.z, pose});
        part = -1;
        j = dir < 0 ? j - 1 : j + 1;
        continue;
      }
      const detail::TrackMotionStep& m = from.motion[std::size_t(found)];
      pose = {pose[0] + dir * m.dx, pose[1] + dir * m.dy, pose[2] + dir * m.da};
      part = dir < 0 ? from.edges[std::size_t(found)].a : from.edges[std::size_t(found)].b;
      j = dir < 0 ? j - 1 : j + 1;
      out.push_back({&next, part, next.z, pose});
    }
    return out;
  };
  auto add = [&](ChainKnot c0, ChainKnot c1) {
    Piece p;
    const std::vector<ChainKnot> below = extend(k, c0.part, c0.pose, -1), above = extend(k + 1, c1.part, c1.pose, +1);
    p.chain.assign(below.rbegin(), below.rend());
    p.i0 = p.chain.size();
    p.chain.push_back(c0);
    p.chain.push_back(c1);
    p.chain.insert(p.chain.end(), above.begin(), above.end());
    const ChainKnot& first = c0.part >= 0 ? c0 : c1;
    p.centre = first.knot->parts.parts[std::size_t(first.part)].centroid;
    p.screw_min = screw_min;
    for (const ChainKnot& c : p.chain) p.moving = p.moving || c.pose != Pose{0, 0, 0};
    // Region: the end parts' shells along the trajectory.
    PixelBox r;
    const int samples = p.moving ? kExtentSamples : 0;
    for (int s = 0; s <= samples; ++s) {
      const Pose pt = p.path(samples ? double(s) / samples : 0.0);
      for (const ChainKnot* c : {&p.lo(), &p.hi()}) {
        if (c->part < 0) continue;
        const PixelBox& b = c->knot->parts.parts[std::size_t(c->part)].shell;
        for (const double x : {double(b.x0), double(b.x1 - 1)})
          for (const double y : {double(b.y0), double(b.y1 - 1)}) {
            const Vec2d q = p.moving ? p.placed(*c, pt, x, y) : Vec2d(x, y);
            const int qx = int(std::floor(q.x())), qy = int(std::floor(q.y()));
            r = joined(r, PixelBox{qx, qy, qx + 2, qy + 2});
          }
      }
    }
    p.region = grown(r, kPieceMargin, width_, height_);
    ++stats_.pieces;
    stats_.moving_pieces += p.moving;
    in->pieces.push_back(std::move(p));
  };
  const Knot &lo = *in->lo, &hi = *in->hi;
  std::vector<char> has_in(hi.parts.parts.size(), 0), has_out(lo.parts.parts.size(), 0);
  for (std::size_t i = 0; i < lo.edges.size(); ++i) {
    const detail::TrackEdge& e = lo.edges[i];
    const detail::TrackMotionStep& m = lo.motion[i];
    has_out[std::size_t(e.a)] = has_in[std::size_t(e.b)] = 1;
    add({&lo, e.a, lo.z, {0, 0, 0}}, {&hi, e.b, hi.z, {m.dx, m.dy, m.da}});
  }
  for (std::size_t a = 0; a < has_out.size(); ++a)  // fades toward the next knot
    if (!has_out[a]) add({&lo, int(a), lo.z, {0, 0, 0}}, {&hi, -1, hi.z, {0, 0, 0}});
  for (std::size_t b = 0; b < has_in.size(); ++b)  // appears from the knot below
    if (!has_in[b]) add({&lo, -1, lo.z, {0, 0, 0}}, {&hi, int(b), hi.z, {0, 0, 0}});

  // A piece that does not move: its knots' values and tangents once.
  const long pixels = long(width_) * long(height_);
  long piece_pixels = 0;
  for (Piece& p : in->pieces) {
    if (p.moving) continue;
    const PixelBox& r = p.region;
    p.f0 = p.f1 = p.m0 = p.m1 = Grid2f(r.width(), r.height());
    const std::size_t n = p.chain.size();
    std::vector<double> zc(n);
    for (std::size_t c = 0; c < n; ++c) zc[c] = p.chain[c].z;
    tbb::parallel_for(tbb::blocked_range<int>(0, r.height(), 8), [&](const tbb::blocked_range<int>& rows) {
      std::vector<double> f(n), m(n);
      for (int y = rows.begin(); y != rows.end(); ++y)
        for (int x = 0; x < r.width(); ++x) {
          for (std::size_t c = 0; c < n; ++c)
            f[c] = p.chain[c].knot->tap(p.chain[c].part, r.x0 + x, r.y0 + y, iso_);
          spline_tangents(kind_, zc, f, m, p.i0, p.i0 + 1);
          p.f0(x, y) = float(f[p.i0]), p.f1(x, y) = float(f[p.i0 + 1]);
          p.m0(x, y) = float(m[p.i0]), p.m1(x, y) = float(m[p.i0 + 1]);
        }
    });
    piece_pixels += 4 * long(r.width()) * long(r.height());
  }
  in->counted = (piece_pixels + pixels - 1) / pixels;
  count(in->counted);
  intervals_.push_back(std::move(in));
  while (intervals_.size() > 2) {  // the mesher's layer reads this interval and the one before
    count(-intervals_.front()->counted);
    intervals_.pop_front();
  }
}

void TrackStream::evaluate(double q, Grid2f& out) const {
  const std::size_t k = interval(q);
  if (intervals_.empty() || intervals_.back()->k != k) throw ParamError("track: evaluate() outside the reached interval");
  const Interval& in = *intervals_.back();
  if (out.width != width_ || out.height != height_) out = Grid2f(width_, height_);
  q = std::clamp(q, z_.front(), z_.back());
  const double z0 = z_[k], z1 = z_[k + 1], t = (q - z0) / (z1 - z0);
  // The background: linear between the knots, each below iso - kTrackShell
  // where it has parts (their pieces read it above that).
  const float cap0 = in.lo->clamped ? iso_ - detail::kTrackShell : std::numeric_limits<float>::infinity();
  const float cap1 = in.hi->clamped ? iso_ - detail::kTrackShell : std::numeric_limits<float>::infinity();
  const float *a = in.lo->field.data.data(), *b = in.hi->field.data.data();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, out.size(), 4096), [&](const auto& r) {
    for (std::size_t p = r.begin(); p != r.end(); ++p) {
      const double v0 = std::min(a[p], cap0), v1 = std::min(b[p], cap1);
      out.data[p] = float(v0 + t * (v1 - v0));
    }
  });
  const HermiteBasis basis(kind_, z0, z1, q);
  for (const Piece& piece : in.pieces) {
    const PixelBox& r = piece.region;
    if (!piece.moving) {
      tbb::parallel_for(tbb::blocked_range<int>(0, r.height(), 8), [&](const tbb::blocked_range<int>& rows) {
        for (int y = rows.begin(); y != rows.end(); ++y)
          for (int x = 0; x < r.width(); ++x) {
            const float v = float(basis.value(piece.f0(x, y), piece.f1(x, y), piece.m0(x, y), piece.m1(x, y)));
            float& o = out(r.x0 + x, r.y0 + y);
            o = std::max(o, v);
          }
      });
      continue;
    }
    const Pose pt = piece.path(t);
    const std::size_t n = piece.chain.size();
    std::vector<double> zc(n);
    std::vector<Piece::View> views(n);
    for (std::size_t c = 0; c < n; ++c) zc[c] = piece.chain[c].z, views[c] = piece.view(piece.chain[c], pt);
    tbb::parallel_for(tbb::blocked_range<int>(0, r.height(), 8), [&](const tbb::blocked_range<int>& rows) {
      std::vector<double> f(n), m(n);
      for (int y = rows.begin(); y != rows.end(); ++y)
        for (int x = 0; x < r.width(); ++x) {
          const int px = r.x0 + x, py = r.y0 + y;
          for (std::size_t c = 0; c < n; ++c) {
            const Vec2d s = views[c].at(px, py);
            f[c] = piece.chain[c].knot->sample(piece.chain[c].part, s.x(), s.y(), iso_);
          }
          spline_tangents(kind_, zc, f, m, piece.i0, piece.i0 + 1);
          const float v = float(basis.value(float(f[piece.i0]), float(f[piece.i0 + 1]), float(m[piece.i0]),
                                            float(m[piece.i0 + 1])));
          float& o = out(px, py);
          o = std::max(o, v);
        }
    });
  }
}

void TrackStream::sides(std::size_t k, float iso, float margin, Grid2<std::int8_t>& out) const {
  const Interval* in = built(k);
  if (!in) throw ParamError("track: sides() of an interval not held");
  if (out.width != width_ || out.height != height_) out = Grid2<std::int8_t>(width_, height_);
  // The background lies between its two knot values (<= iso).
  const float cap0 = in->lo->clamped ? iso_ - detail::kTrackShell : std::numeric_limits<float>::infinity();
  const float cap1 = in->hi->clamped ? iso_ - detail::kTrackShell : std::numeric_limits<float>::infinity();
  for (std::size_t p = 0; p < out.size(); ++p) {
    const float hi = std::max(std::min(in->lo->field.data[p], cap0), std::min(in->hi->field.data[p], cap1));
    out.data[p] = hi < iso - margin ? -1 : 0;
  }
  // A piece that does not move lies within its knots widened by the cubic's
  // overshoot bound (as ZInterpolator::sides); one that moves is unknown.
  const bool between = kind_ == SplineKind::Monotone || kind_ == SplineKind::Linear;
  const float reach = float((z_[k + 1] - z_[k]) * 4.0 / 27.0);
  for (const Piece& piece : in->pieces) {
    const PixelBox& r = piece.region;
    for (int y = 0; y < r.height(); ++y)
      for (int x = 0; x < r.width(); ++x) {
        std::int8_t& o = out(r.x0 + x, r.y0 + y);
        if (o == 1) continue;
        if (piece.moving) {
          o = 0;
          continue;
        }
        const float f0 = piece.f0(x, y), f1 = piece.f1(x, y);
        const float slack = between ? 0.0f : reach * (std::abs(piece.m0(x, y)) + std::abs(piece.m1(x, y)));
        if (std::min(f0, f1) - slack > iso + margin) o = 1;
        else if (std::max(f0, f1) + slack >= iso - margin) o = 0;
      }
  }
}

}  // namespace isoloft
