#include "isoloft/synth/shapes.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "isoloft/core/error.h"
#include "isoloft/synth/tilted_tubes.h"

namespace isoloft {

using nlohmann::json;

namespace {

Vec3d vec3(const json& j, const char* key) {
  if (!j.contains(key) || !j[key].is_array() || j[key].size() != 3) throw ParamError(std::string("shape: field '") + key + "' must be [x, y, z]");
  return {j[key][0].get<double>(), j[key][1].get<double>(), j[key][2].get<double>()};
}
double num(const json& j, const char* key) {
  if (!j.contains(key) || !j[key].is_number()) throw ParamError(std::string("shape: field '") + key + "' must be a number");
  return j[key].get<double>();
}
json arr(const Vec3d& v) { return json::array({v.x(), v.y(), v.z()}); }

// Polynomial smooth minimum of distances outside = smooth maximum of the
// inside-positive values (Quilez): blends within `k` pixels of the seam.
double smooth_max(double a, double b, double k) {
  const double h = std::clamp(0.5 + 0.5 * (a - b) / k, 0.0, 1.0);
  return b + (a - b) * h + k * h * (1.0 - h);
}

class Sphere final : public Shape {
 public:
  Sphere(Vec3d c, double r) : c_(c), r_(r) {}
  double value(const Vec3d& p) const override { return r_ - (p - c_).norm(); }
  bool exact() const override { return true; }
  json to_json() const override { return {{"type", "sphere"}, {"center", arr(c_)}, {"radius", r_}}; }
  std::array<Vec3d, 2> bounds() const override { return {c_ - Vec3d::Constant(r_), c_ + Vec3d::Constant(r_)}; }
  Vec3d normal(const Vec3d& p) const override {
    const Vec3d d = p - c_;
    return d.norm() > 0 ? Vec3d(d.normalized()) : Vec3d(0, 0, 1);
  }
  Vec3d closest_point(const Vec3d& p) const override { return c_ + r_ * normal(p); }
  std::unique_ptr<Shape> translated(const Vec3d& t) const override { return std::make_unique<Sphere>(c_ + t, r_); }

 private:
  Vec3d c_;
  double r_;
};

class Ellipsoid final : public Shape {
 public:
  Ellipsoid(Vec3d c, Vec3d radii) : c_(c), a_(radii) {}
  // Scaled-sphere implicit times the smallest radius: zero set exact, |grad| ~ 1 near the surface.
  double value(const Vec3d& p) const override { return a_.minCoeff() * (1.0 - ((p - c_).cwiseQuotient(a_)).norm()); }
  bool exact() const override { return false; }
  json to_json() const override { return {{"type", "ellipsoid"}, {"center", arr(c_)}, {"radii", arr(a_)}}; }
  std::array<Vec3d, 2> bounds() const override { return {c_ - a_, c_ + a_}; }
  std::unique_ptr<Shape> translated(const Vec3d& t) const override { return std::make_unique<Ellipsoid>(c_ + t, a_); }

 private:
  Vec3d c_, a_;
};

// Torus with major radius R, minor radius r, axis = z rotated by `tilt_deg`
// about the x axis.
class Torus final : public Shape {
 public:
  Torus(Vec3d c, double R, double r, double tilt_deg) : c_(c), R_(R), r_(r), tilt_(tilt_deg) {
    rot_ = Eigen::AngleAxisd(tilt_deg * M_PI / 180.0, Vec3d::UnitX()).toRotationMatrix();
  }
  double value(const Vec3d& p) const override {
    const Vec3d q = rot_.transpose() * (p - c_);
    const double rho = std::hypot(q.x(), q.y());
    return r_ - std::hypot(rho - R_, q.z());
  }
  bool exact() const override { return true; }
  json to_json() const override {
    return {{"type", "torus"}, {"center", arr(c_)}, {"major_radius", R_}, {"minor_radius", r_}, {"tilt_deg", tilt_}};
  }
  std::array<Vec3d, 2> bounds() const override {
    // Bounds of the rotated torus: extent along each world axis.
    Vec3d ext;
    for (int i = 0; i < 3; ++i) {
      const Vec3d axis = rot_.col(2);
      const double s = std::sqrt(std::max(0.0, 1.0 - axis[i] * axis[i]));  // |sin| of angle to the torus axis
      ext[i] = R_ * s + r_;
    }
    return {c_ - ext, c_ + ext};
  }
  Vec3d closest_point(const Vec3d& p) const override {
    const Vec3d q = rot_.transpose() * (p - c_);
    const double rho = std::hypot(q.x(), q.y());
    const Vec3d radial = rho > 0 ? Vec3d(q.x() / rho, q.y() / rho, 0) : Vec3d(1, 0, 0);
    const Vec3d ring = R_ * radial;  // nearest point of the core circle
    const Vec3d d = q - ring;
    const Vec3d foot = ring + (d.norm() > 0 ? Vec3d(r_ * d.normalized()) : Vec3d(r_ * radial));
    return c_ + rot_ * foot;
  }
  Vec3d normal(const Vec3d& p) const override {
    const Vec3d q = rot_.transpose() * (p - c_);
    const double rho = std::hypot(q.x(), q.y());
    const Vec3d radial = rho > 0 ? Vec3d(q.x() / rho, q.y() / rho, 0) : Vec3d(1, 0, 0);
    const Vec3d d = q - R_ * radial;
    return rot_ * (d.norm() > 0 ? Vec3d(d.normalized()) : radial);
  }
  std::unique_ptr<Shape> translated(const Vec3d& t) const override { return std::make_unique<Torus>(c_ + t, R_, r_, tilt_); }

 private:
  Vec3d c_;
  double R_, r_, tilt_;
  Eigen::Matrix3d rot_;
};

// Smooth union of capsules (segments with a radius): "branching cylinders".
class Capsules final : public Shape {
 public:
  struct Capsule {
    Vec3d a, b;
    double r;
  };
  Capsules(std::vector<Capsule> caps, double blend, std::string type) : caps_(std::move(caps)), k_(blend), type_(std::move(type)) {}
  double value(const Vec3d& p) const override {
    double v = -1e300;
    for (const auto& c : caps_) {
      const Vec3d ab = c.b - c.a;
      const double t = std::clamp((p - c.a).dot(ab) / std::max(ab.squaredNorm(), 1e-300), 0.0, 1.0);
      const double d = c.r - (p - (c.a + t * ab)).norm();
      v = v == -1e300 ? d : smooth_max(v, d, k_);
    }
    return v;
  }
  bool exact() const override { return false; }
  json to_json() const override {
    json caps = json::array();
    for (const auto& c : caps_) caps.push_back({{"a", arr(c.a)}, {"b", arr(c.b)}, {"radius", c.r}});
    return {{"type", type_}, {"capsules", caps}, {"blend", k_}};
  }
  std::array<Vec3d, 2> bounds() const override {
    Vec3d lo = Vec3d::Constant(1e300), hi = Vec3d::Constant(-1e300);
    for (const auto& c : caps_) {
      // smooth_max exceeds the plain max by at most k/4.
      lo = lo.cwiseMin(c.a.cwiseMin(c.b) - Vec3d::Constant(c.r + k_ / 4));
      hi = hi.cwiseMax(c.a.cwiseMax(c.b) + Vec3d::Constant(c.r + k_ / 4));
    }
    return {lo, hi};
  }
  std::unique_ptr<Shape> translated(const Vec3d& t) const override {
    auto caps = caps_;
    for (auto& c : caps) c.a += t, c.b += t;
    return std::make_unique<Capsules>(caps, k_, type_);
  }

 private:
  std::vector<Capsule> caps_;
  double k_;
  std::string type_;
};

Vec3d numeric_gradient(const Shape& s, const Vec3d& p) {
  constexpr double h = 1e-4;  // pixels: central differences, error O(h^2) on smooth shapes
  Vec3d g;
  for (int i = 0; i < 3; ++i) {
    Vec3d e = Vec3d::Zero();
    e[i] = h;
    g[i] = (s.value(p + e) - s.value(p - e)) / (2 * h);
  }
  return g;
}

}  // namespace

Vec3d Shape::normal(const Vec3d& p) const {
  const Vec3d g = numeric_gradient(*this, p);
  return g.norm() > 0 ? Vec3d(-g.normalized()) : Vec3d(0, 0, 1);
}

Vec3d Shape::closest_point(const Vec3d& p) const {
  // Newton projection along the gradient; each step is exact for a true
  // distance function, and converges quadratically near a smooth surface.
  Vec3d q = p;
  for (int it = 0; it < 50; ++it) {
    const double f = value(q);
    const Vec3d g = numeric_gradient(*this, q);
    const double g2 = g.squaredNorm();
    if (g2 < 1e-24) break;
    const Vec3d step = f * g / g2;
    q -= step;
    if (step.norm() < 1e-10) break;
  }
  return q;
}

std::unique_ptr<Shape> shape_from_json(const json& j) {
  const std::string type = j.value("type", "");
  if (type == "sphere") return std::make_unique<Sphere>(vec3(j, "center"), num(j, "radius"));
  if (type == "ellipsoid") return std::make_unique<Ellipsoid>(vec3(j, "center"), vec3(j, "radii"));
  if (type == "torus") return std::make_unique<Torus>(vec3(j, "center"), num(j, "major_radius"), num(j, "minor_radius"), j.value("tilt_deg", 0.0));
  if (type == "capsules" || type == "branching-cylinders" || type == "two-blobs") {
    std::vector<Capsules::Capsule> caps;
    if (!j.contains("capsules") || !j["capsules"].is_array()) throw ParamError("shape: 'capsules' must be an array");
    for (const auto& c : j["capsules"]) caps.push_back({vec3(c, "a"), vec3(c, "b"), num(c, "radius")});
    if (caps.empty()) throw ParamError("shape: 'capsules' is empty");
    return std::make_unique<Capsules>(std::move(caps), num(j, "blend"), type);
  }
  if (std::unique_ptr<Shape> tilted = tilted_shape_from_json(j)) return tilted;
  throw ParamError("unknown shape type '" + type + "'");
}

std::vector<std::string> shape_names() {
  return {"sphere", "ellipsoid", "torus", "tilted-torus", "branching-cylinders", "two-blobs"};
}

std::unique_ptr<Shape> make_default_shape(const std::string& name, int size) {
  const double s = size;
  const double c = (s - 1) / 2;  // image centre in pixel-centre coordinates
  if (name == "sphere") return std::make_unique<Sphere>(Vec3d(c, c, 0.35 * s), 0.35 * s);
  if (name == "ellipsoid") return std::make_unique<Ellipsoid>(Vec3d(c, c, 0.3 * s), Vec3d(0.4 * s, 0.25 * s, 0.3 * s));
  if (name == "torus") return std::make_unique<Torus>(Vec3d(c, c, 0.12 * s), 0.28 * s, 0.12 * s, 0.0);
  if (name == "tilted-torus") {
    Torus probe(Vec3d::Zero(), 0.28 * s, 0.12 * s, 60.0);
    const double half = probe.bounds()[1].z();
    return std::make_unique<Torus>(Vec3d(c, c, half), 0.28 * s, 0.12 * s, 60.0);
  }
  if (name == "branching-cylinders") {
    // A trunk along z splitting into two branches (a Y), radius 0.08 size.
    const double r = 0.08 * s, h = 0.9 * s;
    const Vec3d base(c, c, r), fork(c, c, 0.45 * h + r);
    std::vector<Capsules::Capsule> caps = {{base, fork, r},
                                           {fork, Vec3d(c - 0.3 * s, c, h), r},
                                           {fork, Vec3d(c + 0.3 * s, c + 0.05 * s, h), r}};
    return std::make_unique<Capsules>(std::move(caps), 0.05 * s, "branching-cylinders");
  }
  if (name == "two-blobs") {
    // Two balls of radius 0.2 size joined by a thinner neck, blended.
    const double r = 0.2 * s;
    std::vector<Capsules::Capsule> caps = {{Vec3d(c - 0.2 * s, c, r + 0.05 * s), Vec3d(c - 0.2 * s, c, r + 0.05 * s), r},
                                           {Vec3d(c + 0.2 * s, c, r + 0.05 * s + 0.25 * s), Vec3d(c + 0.2 * s, c, r + 0.05 * s + 0.25 * s), r}};
    return std::make_unique<Capsules>(std::move(caps), 0.15 * s, "two-blobs");
  }
  throw ParamError("unknown shape '" + name + "' (expected one of: sphere, ellipsoid, torus, tilted-torus, branching-cylinders, two-blobs)");
}

}  // namespace isoloft
