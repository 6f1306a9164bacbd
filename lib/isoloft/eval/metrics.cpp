#include "isoloft/eval/metrics.h"

#include <Eigen/Geometry>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace isoloft {

nlohmann::json SurfaceStats::to_json() const {
  return {{"area_px2", area},
          {"triangles", triangles},
          {"mean_distance_px", mean_distance},
          {"rms_distance_px", rms_distance},
          {"p99_distance_px", p99_distance},
          {"max_distance_px", max_distance},
          {"mean_normal_angle_deg", mean_normal_angle_deg}};
}

nlohmann::json MeshToShapeStats::to_json() const { return {{"in_range", in_range.to_json()}, {"caps", caps.to_json()}}; }

namespace {

struct FaceSample {
  double area, dist, angle, vmax;
  bool in_range;
};

SurfaceStats summarize(std::vector<FaceSample> s) {
  SurfaceStats r;
  r.triangles = long(s.size());
  if (s.empty()) return r;
  double wsum = 0, d = 0, d2 = 0, ang = 0;
  for (const auto& f : s) {
    wsum += f.area;
    d += f.area * f.dist;
    d2 += f.area * f.dist * f.dist;
    ang += f.area * f.angle;
    r.max_distance = std::max(r.max_distance, f.vmax);
  }
  r.area = wsum;
  if (wsum > 0) {
    r.mean_distance = d / wsum;
    r.rms_distance = std::sqrt(d2 / wsum);
    r.mean_normal_angle_deg = ang / wsum;
    std::sort(s.begin(), s.end(), [](const FaceSample& a, const FaceSample& b) { return a.dist < b.dist; });
    double acc = 0;
    for (const auto& f : s) {
      acc += f.area;
      if (acc >= 0.99 * wsum) {
        r.p99_distance = f.dist;
        break;
      }
    }
  }
  return r;
}

}  // namespace

MeshToShapeStats mesh_to_shape_stats(const TriMesh& mesh, const Shape& shape, double z_first, double z_last) {
  std::vector<FaceSample> faces(mesh.triangles.size());
  std::vector<double> vdist(mesh.vertices.size());
  tbb::parallel_for(std::size_t(0), mesh.vertices.size(), [&](std::size_t i) { vdist[i] = shape.distance(mesh.vertices[i].cast<double>()); });
  tbb::parallel_for(std::size_t(0), mesh.triangles.size(), [&](std::size_t t) {
    const auto& tri = mesh.triangles[t];
    const Vec3d a = mesh.vertices[tri[0]].cast<double>(), b = mesh.vertices[tri[1]].cast<double>(), c = mesh.vertices[tri[2]].cast<double>();
    const Vec3d cross = (b - a).cross(c - a);
    const Vec3d centroid = (a + b + c) / 3.0;
    FaceSample f;
    f.area = 0.5 * cross.norm();
    const Vec3d foot = shape.closest_point(centroid);
    f.dist = (foot - centroid).norm();
    f.angle = 0;
    if (cross.norm() > 0) {
      const double cosang = std::clamp(cross.normalized().dot(shape.normal(foot)), -1.0, 1.0);
      f.angle = std::acos(cosang) * 180.0 / M_PI;
    }
    f.vmax = std::max({f.dist, vdist[tri[0]], vdist[tri[1]], vdist[tri[2]]});
    f.in_range = centroid.z() >= z_first && centroid.z() <= z_last;
    faces[t] = f;
  });
  std::vector<FaceSample> in, caps;
  for (const auto& f : faces) (f.in_range ? in : caps).push_back(f);
  return {summarize(std::move(in)), summarize(std::move(caps))};
}

}  // namespace isoloft
