// @file methods/columns/slice_methods.cpp
// @brief The columns family's slice fields: marker2006's MPU path, the traced
// mask and the drawn polygon paths, the Levin baseline.
#include "isoloft/methods/columns/slice_methods.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "isoloft/contour/mask_curve.h"
#include "isoloft/contour/rasterize.h"
#include "isoloft/core/error.h"
#include "isoloft/field/edt.h"
#include "isoloft/field/filter.h"
#include "isoloft/field/marching.h"
#include "isoloft/field/narrow_band.h"

namespace isoloft::detail {

namespace {
using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }
}  // namespace

namespace {

// The slice's polygons in the box's coordinates.
std::vector<Polygon> polygons_in_box(const Slice& s, const PixelBox& b) {
  std::vector<Polygon> out = s.polygons;
  for (auto& poly : out)
    for (auto& q : poly.points) q -= Vec2d(b.x0, b.y0);
  return out;
}

}  // namespace

Grid2f levin_field(const SliceMasks& m, const PixelBox& b, InputKind kind) {
  const Grid2u8 inside = crop(m.inside, b);
  if (kind == InputKind::Contours || kind == InputKind::Polylines)
    return distance_to_contour_signed(crop(m.contour, b), inside);
  return distance_to_mask_edge_signed(inside);
}

SliceField marker_slice(const SliceInput& in, const ReconstructParams& p) {
  const SliceMasks& m = in.masks;
  const Slice& s = in.slice;
  const PixelBox& b = in.box;
  const InputKind kind = in.kind;
  const bool keep = in.keep_stages;
  const bool polylines = kind == InputKind::Polylines;
  SliceField r;
  auto t0 = Clock::now();
  // Polylines may be fitted on a finer raster (the paper's pelvis): working
  // coordinate x maps to X = k (x + 0.5) - 0.5 (pixel-centre convention at
  // both resolutions), and f is rescaled to working pixels. k = 1 otherwise.
  const bool fine = polylines && p.polyline_raster_width > 0;
  const double k = fine ? double(p.polyline_raster_width) / in.stack_width : 1.0;
  int fit_w = b.width(), fit_h = b.height();
  // The contour pixels and inside over the crop; masks and labels without
  // their features thinner than mask_min_feature (the points, the band and
  // the sign guard all use this mask).
  Grid2u8 contour = crop(m.contour, b), inside = crop(m.inside, b);
  if ((kind == InputKind::Masks || kind == InputKind::Labels) && p.mask_min_feature > 1) {
    inside = remove_thin_features(inside, p.mask_min_feature);
    contour = mask_boundary(inside);
  }
  if (fine) {
    std::vector<Polygon> polys = s.polygons;
    for (auto& poly : polys)
      for (auto& q : poly.points) q = Vec2d(k * (q.x() - b.x0 + 0.5) - 0.5, k * (q.y() - b.y0 + 0.5) - 0.5);
    fit_w = int(std::ceil(k * b.width())), fit_h = int(std::ceil(k * b.height()));
    Grid2u8 fine_contour, fine_inside;
    rasterize_polygons(polys, fit_w, fit_h, fine_contour, fine_inside);
    r.points = contour_normals(fine_contour, fine_inside, p.normals);
  } else if (polylines) {
    r.points = polygon_points(polygons_in_box(s, b), p.polyline_spacing);
  } else {
    r.points = contour_normals(contour, inside, p.normals);
    if (kind != InputKind::Contours && p.mask_edge_offset != 0)
      for (std::size_t i = 0; i < r.points.size(); ++i) r.points.points[i] += p.mask_edge_offset * r.points.normals[i];
  }
  if (r.points.size() < kMinMpuPoints) {
    // Too few oriented points to fit a curve (e.g. a one-pixel island, whose
    // normal is undefined): the slice keeps its exact pixel distance field.
    r.field = levin_field(m, b, kind);
    r.fallback = true;
    r.t_mpu = seconds_since(t0);
    if (keep) r.mpu = r.distance = r.field;
    return r;
  }
  MpuParams mp = p.mpu;
  mp.domain = Eigen::AlignedBox2d(Vec2d(-0.5, -0.5), Vec2d(fit_w - 0.5, fit_h - 0.5));
  // Signed distance to the contour pixels: far from them the fill's
  // inside/outside is exact.
  const bool band = p.mpu_band > 0;
  Grid2f trust;
  if (band || p.sign_guard > 0) trust = distance_to_contour_signed(contour, inside);
  if (band) mp.domain_distance = k * (p.mpu_band + kBandPointMargin);
  r.fit = fit_mpu(r.points, mp);
  if (fine)  // report the points in working crop coordinates
    for (auto& q : r.points.points) q = (q + Vec2d(0.5, 0.5)) / k - Vec2d(0.5, 0.5);
  // The narrow band needs f only near the curve (paper 2.2): with mpu_band,
  // f is evaluated within mpu_band of a contour pixel and the pixels beyond
  // take the fill's signed distance (only their sign is used).
  Grid2u8 where;
  if (band) {
    where = Grid2u8(b.width(), b.height(), 0);
    for (std::size_t i = 0; i < where.size(); ++i) where.data[i] = std::abs(trust.data[i]) <= p.mpu_band;
  }
  Grid2f f = evaluate_on_grid(r.fit.curve, b.width(), b.height(), 0.5 * (k - 1), 0.5 * (k - 1), k, band ? &where : nullptr);
  if (fine)
    for (float& v : f.data) v = float(v / k);
  if (band)
    for (std::size_t i = 0; i < f.size(); ++i)
      if (!where.data[i]) f.data[i] = trust.data[i];
  if (keep) r.mpu = f;  // the raw fit (the fill's distances beyond the band), before the sign guard
  if (p.sign_guard > 0) {
    // Far from every contour pixel the fill's inside/outside is exact; where
    // the fit disagrees there (a spurious zero crossing), the sample takes the
    // signed pixel distance instead, so no curve piece survives out there.
    for (std::size_t i = 0; i < f.size(); ++i)
      if (std::abs(trust.data[i]) > p.sign_guard && (f.data[i] > 0) != (trust.data[i] > 0)) {
        f.data[i] = trust.data[i];
        ++r.sign_guarded;
      }
  }
  r.t_mpu = seconds_since(t0);
  t0 = Clock::now();
  const MpuCurve& curve = r.fit.curve;
  const auto f_working = [&curve, k](const Vec2d& q) { return curve.value(k * (q + Vec2d(0.5, 0.5)) - Vec2d(0.5, 0.5)) / k; };
  const NarrowBandResult nb = narrow_band_distance(f, f_working, p.band);
  r.field = extend_distance(nb, p.extend);
  r.t_dist = seconds_since(t0);
  if (keep) r.distance = r.field;
  return r;
}

SliceField traced_mask_slice(const SliceInput& in, const ReconstructParams& p) {
  SliceField r;
  auto t0 = Clock::now();
  const Grid2f f = clamped_smoothed_mask(crop(in.masks.inside, in.box), p.mask_curve);
  r.t_mpu = seconds_since(t0);
  t0 = Clock::now();
  // Linear vertices (each between its inside and outside pixel centre);
  // saddles by f's sign at the cell centre: join the inside.
  NarrowBandParams band = p.band;
  band.refine_iterations = 0;
  band.segment_splits = 1;
  const NarrowBandResult nb = narrow_band_distance(f, [](const Vec2d&) { return 1.0; }, band);
  r.field = extend_distance(nb, p.extend, in.band ? &in.band->required : nullptr);
  r.t_dist = seconds_since(t0);
  if (in.keep_stages) r.mpu = f, r.distance = r.field;
  return r;
}

SliceField drawn_polygon_slice(const SliceInput& in, const ReconstructParams& p) {
  SliceField r;
  const auto t0 = Clock::now();
  const std::vector<Polygon> shifted = polygons_in_box(in.slice, in.box);
  // The sign by the even-odd rule alone: a contour pixel whose centre lies
  // outside is outside (the masks' inside holds every contour pixel).
  const NarrowBandResult nb = polygon_narrow_band(shifted, even_odd_inside(shifted, in.box.width(), in.box.height()), p.band);
  // No edge (degenerate polygons): the exact pixel distances, as a fit with too few points.
  r.field = nb.segments.empty() ? levin_field(in.masks, in.box, in.kind)
                                 : extend_distance(nb, p.extend, in.band ? &in.band->required : nullptr);
  r.fallback = nb.segments.empty();
  r.t_dist = seconds_since(t0);
  if (in.keep_stages) r.mpu = nb.distance, r.distance = r.field;
  return r;
}

bool takes_given_boundary(InputKind kind, const ReconstructParams& p) {
  const bool traced = (kind == InputKind::Masks || kind == InputKind::Labels) && p.mask_boundary == MaskBoundary::Traced;
  return traced || (kind == InputKind::Polylines && p.polyline_boundary == PolylineBoundary::Drawn);
}

SliceField curve_slice(const SliceInput& in, const ReconstructParams& p) {
  if (in.band && !takes_given_boundary(in.kind, p))
    throw ParamError("curve_slice: a field band needs the input's own boundary (methods/columns/field_band.h)");
  SliceField r = !takes_given_boundary(in.kind, p) ? marker_slice(in, p)
                 : in.kind == InputKind::Polylines ? drawn_polygon_slice(in, p)
                                                   : traced_mask_slice(in, p);
  if (p.filter.enabled) {
    const auto t0 = Clock::now();
    r.field = distance_filter(r.field, p.filter, in.band ? &in.band->needed : nullptr);
    r.t_filter = seconds_since(t0);
  }
  return r;
}

}  // namespace isoloft::detail
