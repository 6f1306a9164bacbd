// @file synth/sections.cpp
// @brief Plane sections of analytic shapes (synth/sections.h).
#include "isoloft/synth/sections.h"

#include <cmath>
#include <random>
#include <string>

#include "isoloft/field/narrow_band.h"

namespace isoloft {

/// Illinois steps placing each traced vertex on the surface (to rounding).
constexpr int kSectionRefineSteps = 40;

PlanePose pose_from_normal(const Vec3d& point, const Vec3d& normal) {
  const Vec3d n = normal.normalized();
  const Vec3d helper = std::abs(n.x()) < 0.9 ? Vec3d::UnitX() : Vec3d::UnitY();
  PlanePose p;
  p.origin = point;
  p.u = helper.cross(n).normalized();
  p.v = n.cross(p.u);
  return p;
}

std::vector<PlanePose> random_poses(const Shape& shape, int n, std::uint32_t seed) {
  const auto [lo, hi] = shape.bounds();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.2, 0.8);
  std::normal_distribution<double> gauss;
  std::vector<PlanePose> out;
  for (int i = 0; i < n; ++i) {
    const Vec3d point = lo + (hi - lo).cwiseProduct(Vec3d(unit(rng), unit(rng), unit(rng)));
    Vec3d normal(gauss(rng), gauss(rng), gauss(rng));
    out.push_back(pose_from_normal(point, normal));
  }
  return out;
}

std::vector<PlanePose> orthogonal_poses(const Shape& shape) {
  const auto [lo, hi] = shape.bounds();
  const Vec3d c = (lo + hi) / 2;
  return {pose_from_normal(c, Vec3d::UnitX()), pose_from_normal(c, Vec3d::UnitY()), pose_from_normal(c, Vec3d::UnitZ())};
}

std::vector<PlanePose> parallel_poses(const Shape& shape, int n) {
  const auto [lo, hi] = shape.bounds();
  const Vec3d c = (lo + hi) / 2;
  std::vector<PlanePose> out;
  for (int i = 0; i < n; ++i) {
    const double z = lo.z() + (hi.z() - lo.z()) * (0.1 + 0.8 * (n > 1 ? double(i) / (n - 1) : 0.5));
    out.push_back(pose_from_normal({c.x(), c.y(), z}, Vec3d::UnitZ()));
  }
  return out;
}

std::vector<Section> analytic_sections(const Shape& shape, const std::vector<PlanePose>& poses, double pixel) {
  const auto [lo, hi] = shape.bounds();
  std::vector<Section> out;
  for (std::size_t p = 0; p < poses.size(); ++p) {
    const PlanePose& pose = poses[p];
    Vec2d pmin = Vec2d::Constant(1e300), pmax = Vec2d::Constant(-1e300);
    for (int c = 0; c < 8; ++c) {
      const Vec2d q = pose.to_plane({c & 1 ? hi.x() : lo.x(), c & 2 ? hi.y() : lo.y(), c & 4 ? hi.z() : lo.z()});
      pmin = pmin.cwiseMin(q);
      pmax = pmax.cwiseMax(q);
    }
    // A margin of 2 pixels, offset by an irrational share so no sample of a
    // centred plane lands exactly on the surface (a zero sample makes a
    // zero-length segment that breaks the loop).
    pmin.array() -= (2 + 1 / std::sqrt(2.0)) * pixel;
    pmax.array() += 2 * pixel;
    const int w = int(std::ceil((pmax.x() - pmin.x()) / pixel)) + 1, h = int(std::ceil((pmax.y() - pmin.y()) / pixel)) + 1;
    const auto to_plane = [&](const Vec2d& px) { return Vec2d(pmin + px * pixel); };
    const ImplicitFn f = [&](const Vec2d& px) { return shape.value(pose.to_world(to_plane(px))); };
    Grid2f samples(w, h);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) samples(x, y) = float(f({double(x), double(y)}));
    const detail::ZeroSet zs = detail::marching_squares(samples, f, kSectionRefineSteps, 1);
    Section sec;
    sec.pose = pose;
    sec.source = "analytic plane " + std::to_string(p);
    std::vector<char> used(zs.segments.size(), 0);
    for (std::size_t start = 0; start < zs.segments.size(); ++start) {
      if (used[start]) continue;
      SectionContour loop;
      std::size_t k = start;
      int end = 1;  // the end of segment k we leave by
      bool closed = false;
      while (true) {
        used[k] = 1;
        loop.points.push_back(to_plane(zs.segments[k][1 - end]));
        const std::int32_t next = zs.links[k][end];
        if (next < 0) break;
        const Vec2d& at = zs.segments[k][end];
        end = zs.segments[std::size_t(next)][0] == at ? 1 : 0;
        k = std::size_t(next);
        if (k == start) {
          closed = true;
          break;
        }
        if (used[k]) break;
      }
      if (closed && loop.points.size() >= 3) sec.contours.push_back(std::move(loop));
    }
    out.push_back(std::move(sec));
  }
  return out;
}

}  // namespace isoloft
