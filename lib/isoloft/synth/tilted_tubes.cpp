#include "isoloft/synth/tilted_tubes.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <sstream>

#include "isoloft/core/error.h"

namespace isoloft {

using nlohmann::json;

namespace {

constexpr double kDeg = M_PI / 180.0;
// A foot point this far inside (px) is not on the surface: far above the
// rounding of a distance of ~100 px, far below any feature.
constexpr double kOnSurface = 1e-9;

json point(const Vec3d& p) { return json::array({p.x(), p.y(), p.z()}); }
Vec3d point(const json& j) {
  if (!j.is_array() || j.size() != 3) throw ParamError("shape: a point must be [x, y, z]");
  return {j[0].get<double>(), j[1].get<double>(), j[2].get<double>()};
}

// Nearest point of segment ab to p.
Vec3d nearest_on_segment(const Vec3d& p, const Vec3d& a, const Vec3d& b) {
  const Vec3d ab = b - a;
  const double t = std::clamp((p - a).dot(ab) / std::max(ab.squaredNorm(), 1e-300), 0.0, 1.0);
  return a + t * ab;
}

// A ball of radius r swept along polylines.
class Tubes final : public Shape {
 public:
  Tubes(std::vector<std::vector<Vec3d>> lines, double r) : lines_(std::move(lines)), r_(r) { index(); }
  double value(const Vec3d& p) const override { return r_ - (p - axis_point(p)).norm(); }
  bool exact() const override { return true; }
  json to_json() const override {
    json lines = json::array();
    for (const auto& l : lines_) {
      json pts = json::array();
      for (const Vec3d& q : l) pts.push_back(point(q));
      lines.push_back(pts);
    }
    return {{"type", "tubes"}, {"radius", r_}, {"polylines", lines}};
  }
  std::array<Vec3d, 2> bounds() const override {
    Vec3d lo = Vec3d::Constant(1e300), hi = Vec3d::Constant(-1e300);
    for (const auto& l : lines_)
      for (const Vec3d& q : l) lo = lo.cwiseMin(q), hi = hi.cwiseMax(q);
    return {lo - Vec3d::Constant(r_), hi + Vec3d::Constant(r_)};
  }
  Vec3d normal(const Vec3d& p) const override {
    const Vec3d d = p - axis_point(p);
    return d.norm() > 0 ? Vec3d(d.normalized()) : Vec3d(0, 0, 1);
  }
  Vec3d closest_point(const Vec3d& p) const override {
    const Vec3d foot = axis_point(p) + r_ * normal(p);
    // Inside, near a crease where tubes meet, that foot lies inside another
    // tube: Newton steps along the gradient reach the surface.
    return value(foot) > kOnSurface ? Shape::closest_point(foot) : foot;
  }
  std::unique_ptr<Shape> translated(const Vec3d& t) const override {
    auto lines = lines_;
    for (auto& l : lines)
      for (Vec3d& q : l) q += t;
    return std::make_unique<Tubes>(std::move(lines), r_);
  }

 private:
  // The nearest point of the polylines: the segments in z slabs outward from
  // p's, until the next slab lies farther than the best so far.
  Vec3d axis_point(const Vec3d& p) const {
    Vec3d best = lines_.front().front();
    double best_d = 1e300;
    const long n = long(slabs_.size());
    const long home = std::clamp(long(std::floor((p.z() - z0_) / slab_)), 0L, n - 1);
    for (long k = 0; k < n; ++k) {
      // Slabs home - k and home + k (and all beyond) lie at least this far from p in z.
      constexpr double kNone = std::numeric_limits<double>::infinity();
      const double below = home - k >= 0 ? p.z() - (z0_ + double(home - k + 1) * slab_) : kNone;
      const double above = home + k < n ? z0_ + double(home + k) * slab_ - p.z() : kNone;
      const double gap = std::max(0.0, std::min(below, above));
      if (k > 0 && gap * gap >= best_d) break;
      for (const long s : {home - k, home + k}) {
        if (s < 0 || s >= n || (k == 0 && s != home) || (k > 0 && s == home)) continue;
        for (const auto& [li, i] : slabs_[std::size_t(s)]) {
          const Vec3d &a = lines_[li][i], &b = lines_[li][i + 1];
          // A segment whose box lies farther than the best so far cannot be nearer.
          if ((p.cwiseMax(a.cwiseMin(b)).cwiseMin(a.cwiseMax(b)) - p).squaredNorm() >= best_d) continue;
          const Vec3d q = nearest_on_segment(p, a, b);
          if (const double d = (p - q).squaredNorm(); d < best_d) best_d = d, best = q;
        }
      }
    }
    return best;
  }

  // Each segment in every z slab its z range meets.
  void index() {
    double z1 = -1e300;
    z0_ = 1e300;
    for (const auto& l : lines_)
      for (const Vec3d& q : l) z0_ = std::min(z0_, q.z()), z1 = std::max(z1, q.z());
    slab_ = std::max(r_, (z1 - z0_) / kMaxSlabs);
    slabs_.assign(std::size_t(std::floor((z1 - z0_) / slab_)) + 1, {});
    for (std::size_t li = 0; li < lines_.size(); ++li)
      for (std::size_t i = 0; i + 1 < lines_[li].size(); ++i) {
        const double lo = std::min(lines_[li][i].z(), lines_[li][i + 1].z()), hi = std::max(lines_[li][i].z(), lines_[li][i + 1].z());
        for (auto s = std::size_t((lo - z0_) / slab_); s <= std::size_t((hi - z0_) / slab_) && s < slabs_.size(); ++s)
          slabs_[s].emplace_back(li, i);
      }
  }

  static constexpr double kMaxSlabs = 256;
  std::vector<std::vector<Vec3d>> lines_;
  double r_;
  double z0_ = 0, slab_ = 1;
  std::vector<std::vector<std::pair<std::size_t, std::size_t>>> slabs_;
};

// A union of balls.
class Balls final : public Shape {
 public:
  Balls(std::vector<Vec3d> c, std::vector<double> r) : c_(std::move(c)), r_(std::move(r)) {}
  double value(const Vec3d& p) const override {
    const std::size_t i = nearest(p);
    return r_[i] - (p - c_[i]).norm();
  }
  bool exact() const override { return true; }
  json to_json() const override {
    json c = json::array();
    for (const Vec3d& q : c_) c.push_back(point(q));
    return {{"type", "balls"}, {"centers", c}, {"radii", r_}};
  }
  std::array<Vec3d, 2> bounds() const override {
    Vec3d lo = Vec3d::Constant(1e300), hi = Vec3d::Constant(-1e300);
    for (std::size_t i = 0; i < c_.size(); ++i)
      lo = lo.cwiseMin(c_[i] - Vec3d::Constant(r_[i])), hi = hi.cwiseMax(c_[i] + Vec3d::Constant(r_[i]));
    return {lo, hi};
  }
  Vec3d normal(const Vec3d& p) const override {
    const Vec3d d = p - c_[nearest(p)];
    return d.norm() > 0 ? Vec3d(d.normalized()) : Vec3d(0, 0, 1);
  }
  Vec3d closest_point(const Vec3d& p) const override {
    const std::size_t i = nearest(p);
    return c_[i] + r_[i] * normal(p);
  }
  std::unique_ptr<Shape> translated(const Vec3d& t) const override {
    auto c = c_;
    for (Vec3d& q : c) q += t;
    return std::make_unique<Balls>(std::move(c), r_);
  }

 private:
  // The ball of the largest value at p.
  std::size_t nearest(const Vec3d& p) const {
    std::size_t best = 0;
    for (std::size_t i = 1; i < c_.size(); ++i)
      if (r_[i] - (p - c_[i]).norm() > r_[best] - (p - c_[best]).norm()) best = i;
    return best;
  }

  std::vector<Vec3d> c_;
  std::vector<double> r_;
};

// The lines moved so that their xy bounds start kTiltedMargin + r from 0;
// the image holds them with that margin on every side.
TiltedCase tube_case(std::string name, std::vector<std::vector<Vec3d>> lines, double r, std::vector<double> slice_z,
                      int components, json params) {
  Vec3d lo = Vec3d::Constant(1e300), hi = Vec3d::Constant(-1e300);
  for (const auto& l : lines)
    for (const Vec3d& q : l) lo = lo.cwiseMin(q), hi = hi.cwiseMax(q);
  const Vec3d shift(kTiltedMargin + r - lo.x(), kTiltedMargin + r - lo.y(), 0);
  for (auto& l : lines)
    for (Vec3d& q : l) q += shift;
  TiltedCase c;
  c.name = std::move(name);
  c.width = int(std::ceil(hi.x() + shift.x() + r + kTiltedMargin)) + 1;
  c.height = int(std::ceil(hi.y() + shift.y() + r + kTiltedMargin)) + 1;
  c.shape = std::make_unique<Tubes>(std::move(lines), r);
  c.slice_z = std::move(slice_z);
  c.components = components;
  params["radius"] = r;
  c.params = std::move(params);
  return c;
}

std::vector<double> slices(int n, double spacing) {
  std::vector<double> z(std::size_t(std::max(n, 0)));
  for (int k = 0; k < n; ++k) z[std::size_t(k)] = k * spacing;
  return z;
}

void check_positive(double v, const char* what) {
  if (!(v > 0) || !std::isfinite(v)) throw ParamError(std::string("tilted-tube shape: ") + what + " must be positive");
}

std::string num(double v) {
  std::ostringstream o;
  o << v;
  return o.str();
}

}  // namespace

TiltedCase tilted_tube(double tilt_deg, double r, double spacing, int n_slices, double azimuth_deg) {
  check_positive(r, "the radius"), check_positive(spacing, "the spacing");
  if (!(tilt_deg >= 0 && tilt_deg < 89)) throw ParamError("tilted tube: the tilt must be in [0, 89) deg");
  if (n_slices < 2) throw ParamError("tilted tube: at least 2 slices");
  const double th = tilt_deg * kDeg, az = azimuth_deg * kDeg;
  const Vec3d u(std::sin(th) * std::cos(az), std::sin(th) * std::sin(az), std::cos(th));
  // Its ends lie half a spacing plus r beyond the first and last slice: every slice cuts a full ellipse.
  const double z0 = -0.5 * spacing - r, z1 = (n_slices - 0.5) * spacing + r;
  return tube_case("tube" + num(tilt_deg) + "_r" + num(r) + "_s" + num(spacing), {{u * (z0 / u.z()), u * (z1 / u.z())}},
                   r, slices(n_slices, spacing), 1,
                   {{"shape", "tube"}, {"tilt_deg", tilt_deg}, {"spacing", spacing}, {"azimuth_deg", azimuth_deg}});
}

TiltedCase tilted_fork(double r, double spacing, double branch_deg, int trunk_slices, int branch_slices,
                         double azimuth_deg) {
  check_positive(r, "the radius"), check_positive(spacing, "the spacing");
  if (!(branch_deg >= 0 && branch_deg < 89)) throw ParamError("tilted fork: the branch angle must be in [0, 89) deg");
  if (trunk_slices < 1 || branch_slices < 1) throw ParamError("tilted fork: at least 1 trunk and 1 branch slice");
  const double az = azimuth_deg * kDeg, b = branch_deg * kDeg;
  const double zj = (trunk_slices - 0.5) * spacing;  // the junction, midway between two slices
  const double ztop = (trunk_slices + branch_slices - 0.5) * spacing + r;
  const Vec3d junction(0, 0, zj);
  std::vector<std::vector<Vec3d>> lines{{Vec3d(0, 0, -0.5 * spacing - r), junction}};
  for (const double sgn : {1.0, -1.0}) {
    const Vec3d u(sgn * std::sin(b) * std::cos(az), sgn * std::sin(b) * std::sin(az), std::cos(b));
    lines.push_back({junction, junction + u * ((ztop - zj) / u.z())});
  }
  return tube_case("fork" + num(branch_deg) + "_r" + num(r) + "_s" + num(spacing), std::move(lines), r,
                   slices(trunk_slices + branch_slices, spacing), 1,
                   {{"shape", "fork"}, {"branch_deg", branch_deg}, {"spacing", spacing}});
}

TiltedCase tilted_helix(double r, double coil_radius, double pitch, double spacing, double turns) {
  check_positive(r, "the radius"), check_positive(spacing, "the spacing"), check_positive(coil_radius, "the coil radius");
  check_positive(pitch, "the pitch"), check_positive(turns, "the turns");
  constexpr double kSegmentDeg = 2.0;  // the axis polyline's step: chord error R (1 - cos 1 deg) = 0.003 px at R = 20
  const int n = int(std::ceil(turns * 360.0 / kSegmentDeg));
  std::vector<Vec3d> line;
  for (int i = 0; i <= n; ++i) {
    const double t = turns * 2 * M_PI * i / n;
    line.emplace_back(coil_radius * std::cos(t), coil_radius * std::sin(t), t / (2 * M_PI) * pitch);
  }
  // Slices cut the tube clear of its end balls (1 px).
  std::vector<double> z;
  for (double zz = spacing * std::ceil((line.front().z() + r + 1) / spacing); zz <= line.back().z() - r - 1 + 1e-9;
       zz += spacing)
    z.push_back(zz);
  const double tilt = std::atan2(2 * M_PI * coil_radius, pitch) / kDeg;
  return tube_case("helix_r" + num(r) + "_R" + num(coil_radius) + "_p" + num(pitch) + "_s" + num(spacing), {line}, r,
                   std::move(z), 1,
                   {{"shape", "helix"}, {"coil_radius", coil_radius}, {"pitch", pitch}, {"spacing", spacing},
                    {"tilt_deg", tilt}});
}

TiltedCase two_spheres(double radius, double spacing, double gap, int n_slices) {
  check_positive(radius, "the radius"), check_positive(spacing, "the spacing");
  if (n_slices < 4) throw ParamError("two spheres: at least 4 slices");
  // One centred on slice 1, the other on slice 2, their discs `gap` apart in x.
  std::vector<Vec3d> c{{0, 0, spacing}, {2 * radius + gap, 0, 2 * spacing}};
  const double pad = kTiltedMargin + radius;
  for (Vec3d& q : c) q += Vec3d(pad, pad, 0);
  TiltedCase out;
  out.name = "two_spheres_R" + num(radius) + "_s" + num(spacing) + "_gap" + num(gap);
  out.width = int(std::ceil(c[1].x() + pad)) + 1;
  out.height = int(std::ceil(c[1].y() + pad)) + 1;
  out.shape = std::make_unique<Balls>(std::move(c), std::vector<double>{radius, radius});
  out.slice_z = slices(n_slices, spacing);
  out.components = 2;
  out.params = {{"shape", "two-spheres"}, {"radius", radius}, {"gap", gap}, {"spacing", spacing}};
  return out;
}

TiltedCase two_columns(double radius, double spacing, double gap, int per_column) {
  check_positive(radius, "the radius"), check_positive(spacing, "the spacing");
  if (per_column < 1) throw ParamError("two columns: at least 1 slice each");
  // Side by side in x; the first on slices 0 .. n - 1, the second on n .. 2n - 1.
  const double dx = 2 * radius + gap;
  std::vector<std::vector<Vec3d>> lines{{Vec3d(0, 0, 0), Vec3d(0, 0, (per_column - 1) * spacing)},
                                        {Vec3d(dx, 0, per_column * spacing), Vec3d(dx, 0, (2 * per_column - 1) * spacing)}};
  return tube_case("two_columns_R" + num(radius) + "_s" + num(spacing) + "_gap" + num(gap), std::move(lines), radius,
                   slices(2 * per_column, spacing), 2, {{"shape", "two-columns"}, {"gap", gap}, {"spacing", spacing}});
}

TiltedCase two_bars(double radius, double length, double spacing, double gap, bool end_to_end, int n_slices) {
  check_positive(radius, "the radius"), check_positive(spacing, "the spacing"), check_positive(length, "the length");
  if (n_slices < 4) throw ParamError("two bars: at least 4 slices");
  // Horizontal capsules along x, on slices 1 and 2: beside each other in y,
  // or end to end in x (what an oblique tube seen twice looks like).
  const double z1 = spacing, z2 = 2 * spacing;
  std::vector<std::vector<Vec3d>> lines{{Vec3d(0, 0, z1), Vec3d(length, 0, z1)}};
  if (end_to_end)
    lines.push_back({Vec3d(length + 2 * radius + gap, 0, z2), Vec3d(2 * length + 2 * radius + gap, 0, z2)});
  else
    lines.push_back({Vec3d(0, 2 * radius + gap, z2), Vec3d(length, 2 * radius + gap, z2)});
  const std::string how = end_to_end ? "end" : "side";
  return tube_case("two_bars_" + how + "_R" + num(radius) + "_L" + num(length) + "_s" + num(spacing) + "_gap" + num(gap),
                   std::move(lines), radius, slices(n_slices, spacing), 2,
                   {{"shape", "two-bars-" + how}, {"length", length}, {"gap", gap}, {"spacing", spacing}});
}

std::vector<std::string> tilted_shape_names() {
  return {"tube", "fork", "helix", "two-spheres", "two-columns", "two-bars-side", "two-bars-end"};
}

TiltedCase make_tilted_shape(const std::string& name, const TiltedOptions& o) {
  const int n = o.slices;
  if (name == "tube") return tilted_tube(o.tilt, o.radius, o.spacing, n ? n : 5);
  if (name == "fork") return tilted_fork(o.radius, o.spacing, o.tilt, n ? (n + 1) / 2 : 3, n ? n / 2 : 3);
  if (name == "helix") return tilted_helix(o.radius, 20, 48, o.spacing);
  if (name == "two-spheres") return two_spheres(o.radius, o.spacing, o.gap, n ? n : 4);
  if (name == "two-columns") return two_columns(o.radius, o.spacing, o.gap, n ? (n + 1) / 2 : 3);
  if (name == "two-bars-side" || name == "two-bars-end")
    return two_bars(o.radius, 16, o.spacing, o.gap, name == "two-bars-end", n ? n : 4);
  throw ParamError("unknown tilted-tube shape '" + name + "'");
}

namespace {
// The kit of the research (tilted_tubes_kit.py), by name.
const std::vector<std::pair<std::string, std::function<TiltedCase()>>>& kit() {
  static const std::vector<std::pair<std::string, std::function<TiltedCase()>>> k{
      {"tube80_r3_s8", [] { return tilted_tube(80, 3, 8); }},
      {"tube70_r4_s8", [] { return tilted_tube(70, 4, 8); }},
      {"fork60_r3_s8", [] { return tilted_fork(3, 8, 60); }},
      {"tube45_r3_s8", [] { return tilted_tube(45, 3, 8); }},
      {"tube60_r2_s8", [] { return tilted_tube(60, 2, 8); }},
      {"tube85_r2_s8", [] { return tilted_tube(85, 2, 8); }},
      {"tube85_r5_s8", [] { return tilted_tube(85, 5, 8); }},
      {"tube80_r3_s4", [] { return tilted_tube(80, 3, 4, 7); }},
      {"tube70_r2_s6", [] { return tilted_tube(70, 2, 6, 6); }},
      {"fork60_r4_s4", [] { return tilted_fork(4, 4, 60, 4, 5); }},
      {"helix_r3_s8", [] { return tilted_helix(3, 20, 48, 8); }},
      {"helix_r4_s6", [] { return tilted_helix(4, 16, 40, 6); }},
      // Controls: upright tubes, whose cross-sections do not move (what the slice fields alone lose).
      {"tube0_r2_s8", [] { return tilted_tube(0, 2, 8); }},
      {"tube0_r3_s8", [] { return tilted_tube(0, 3, 8); }},
      {"two_spheres_R6_s8", [] { return two_spheres(6, 8, 4); }},
      {"two_spheres_R4_s8_gap2", [] { return two_spheres(4, 8, 2); }},
      {"two_columns_R5_s8", [] { return two_columns(5, 8, 4); }},
      {"two_bars_side_s8", [] { return two_bars(3, 16, 8, 4, false); }},
      {"two_bars_end_s8", [] { return two_bars(3, 16, 8, 4, true); }},
  };
  return k;
}
}  // namespace

std::vector<std::string> tilted_kit_names() {
  std::vector<std::string> out;
  for (const auto& [name, make] : kit()) out.push_back(name);
  return out;
}

TiltedCase tilted_kit_case(const std::string& name) {
  for (const auto& [n, make] : kit())
    if (n == name) {
      TiltedCase c = make();
      c.name = name;
      return c;
    }
  throw ParamError("unknown tilted-tube kit case '" + name + "'");
}

SynthResult synthesize(const TiltedCase& c, InputKind kind, double polyline_step) {
  SynthParams p;
  p.kind = kind;
  p.polyline_step = polyline_step;
  SynthResult r = synthesize_at(*c.shape, c.slice_z, c.width, c.height, p);
  r.description["components"] = c.components;
  r.description["case"] = c.name;
  r.description["case_params"] = c.params;
  return r;
}

std::unique_ptr<Shape> tilted_shape_from_json(const json& j) {
  const std::string type = j.value("type", "");
  if (type == "tubes") {
    if (!j.contains("polylines") || !j["polylines"].is_array() || j["polylines"].empty())
      throw ParamError("shape: 'polylines' must be a non-empty array");
    std::vector<std::vector<Vec3d>> lines;
    for (const json& l : j["polylines"]) {
      std::vector<Vec3d> pts;
      for (const json& q : l) pts.push_back(point(q));
      if (pts.size() < 2) throw ParamError("shape: a polyline needs at least 2 points");
      lines.push_back(std::move(pts));
    }
    if (!j.contains("radius") || !j["radius"].is_number()) throw ParamError("shape: field 'radius' must be a number");
    return std::make_unique<Tubes>(std::move(lines), j["radius"].get<double>());
  }
  if (type == "balls") {
    if (!j.contains("centers") || !j.contains("radii") || !j["centers"].is_array() || !j["radii"].is_array() ||
        j["centers"].size() != j["radii"].size() || j["centers"].empty())
      throw ParamError("shape: 'centers' and 'radii' must be arrays of one non-zero length");
    std::vector<Vec3d> c;
    std::vector<double> r;
    for (const json& q : j["centers"]) c.push_back(point(q));
    for (const json& q : j["radii"]) r.push_back(q.get<double>());
    return std::make_unique<Balls>(std::move(c), std::move(r));
  }
  return nullptr;
}

}  // namespace isoloft
