// @file methods/columns/work_estimate.cpp
// @brief An object's cost from its packed masks, before any fit
// (estimate_work(), methods/columns/column_stream.h; ReconstructOptions::on_estimate).
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>

#include "isoloft/methods/method.h"
#include "isoloft/methods/columns/column_stream.h"

namespace isoloft::detail {

namespace {

// Estimate constants (docs/decisions.md, work budget: measured on the
// synthetic sphere and the frog).
// Live float copies of each resident slice field: the field, the spline's
// coefficients and one stage's output beside its input.
constexpr double kFieldCopies = 3;
// Bytes of a mesh triangle before decimation, at the peak: vertices and
// triangles, the decimator's quadrics, edge heap and links, the mesh check's
// edge map.
constexpr double kBytesPerTriangle = 160;
// Bytes a fine polyline raster pixel holds while fitted: the contour and
// inside masks.
constexpr double kRasterBytesPerPixel = 2;

// mesh_planes().size(), without making them.
double plane_count(const std::vector<double>& z, const InterpParams& interp) {
  if (!interp.planes_on_slices || z.size() < 3)
    return std::max(0.0, std::ceil((z.back() - z.front()) / interp.z_step - 1e-9)) + 1;
  return std::ceil((z[1] - z.front()) / interp.z_step) + std::ceil((z.back() - z[1]) / interp.z_step) + 1;
}

// Pixels in the runs of a packed mask (begin, end, begin, end, ...).
double run_pixels(const std::vector<std::uint32_t>& runs) {
  double n = 0;
  for (std::size_t i = 0; i + 1 < runs.size(); i += 2) n += double(runs[i + 1] - runs[i]);
  return n;
}

}  // namespace

// Marching Cubes crosses the surface ~2 triangles per pixel of contour per
// plane: between two slices the contour length runs from one's to the
// other's; the caps add their end contour's band and ~2 triangles per
// inside pixel of the end slices. Fields resident at once: the slices
// computed together, the spline's knots around a block, the caps.
WorkEstimate estimate_work(const Run& run, const std::vector<PackedMasks>& masks, const ObjectResult& obj,
                           std::size_t window) {
  const ReconstructParams& p = run.params;
  WorkEstimate e;
  e.label = obj.label;
  e.box = obj.box;
  e.slices = long(run.slices());
  const std::vector<double> z = knot_z(run);
  e.planes = plane_count(z, p.interp);
  const std::size_t n = masks.size();
  std::vector<double> perimeter(n + 2, 0.0), area(n + 2, 0.0);
  for (std::size_t k = 0; k < n; ++k) {
    if (masks[k].empty) continue;
    perimeter[k + 1] = run_pixels(masks[k].contour);
    area[k + 1] = run_pixels(masks[k].inside);
  }
  perimeter[0] = perimeter[1], perimeter[n + 1] = perimeter[n];
  for (std::size_t k = 0; k + 1 < z.size(); ++k)
    e.triangles += (perimeter[k] + perimeter[k + 1]) * (z[k + 1] - z[k]) / p.interp.z_step;
  e.triangles += 2 * (area[1] + area[n]);
  const double pixels = double(obj.box.width()) * double(obj.box.height());
  e.plane_bytes = double(obj.box.width() + 2) * double(obj.box.height() + 2) * sizeof(float);
  const std::optional<std::size_t> knots = z_scheme_spec(p.z_scheme).resident_knots(p);
  const double batches = 2.0 * double(window > 0 ? window : slice_window());  // the batch handed out and the next
  const double resident = batches + (knots ? double(*knots) : double(n)) + 2;
  e.field_bytes = std::min(double(n + 2), resident) * pixels * sizeof(float) * kFieldCopies;
  if (run.stack.kind == InputKind::Polylines && fits_curves(p.method) && p.polyline_raster_width > 0) {
    const double k = double(p.polyline_raster_width) / run.stack.width;
    const double in_flight = std::min(double(n), double(tbb::this_task_arena::max_concurrency()));
    e.field_bytes += in_flight * k * k * pixels * kRasterBytesPerPixel;
  }
  e.mesh_bytes = e.triangles * kBytesPerTriangle;
  return e;
}

}  // namespace isoloft::detail
