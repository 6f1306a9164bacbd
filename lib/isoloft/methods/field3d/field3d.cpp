// @file methods/field3d/field3d.cpp
// @brief field3d: one smooth 3D field constrained by every drawn section, in
// any orientation (the solver: field3d/field3d.h). It reads sections, not
// slices: a reader's sections (CSL; label images on any plane, traced), a
// polygon stack's slices as parallel sections, or a mask or label stack's
// slices as label-image sections traced to their sub-pixel boundary
// (field3d/image_sections.h); it has no per-slice field, so it is a family of
// its own (MethodSpec::reconstruct).
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>

#include "isoloft/core/error.h"
#include "isoloft/core/option_names.h"
#include "isoloft/field3d/image_sections.h"
#include "isoloft/field3d/partition3d.h"
#include "isoloft/methods/method.h"
#include "isoloft/methods/params.h"
#include "isoloft/objects/slice_fields.h"

namespace isoloft {

namespace {

/// One object's sections as the solver reads them (polylines only), with
/// the label it reconstructs and the finest pixel of its image sections (0: none).
struct ObjectSections {
  std::uint32_t label = 0;  ///< the solver's label
  std::uint32_t object = 0; ///< ObjectResult::label (0: the one object of a mask or polygon stack)
  std::vector<Section> sections;
  double pixel = 0;
};

bool asked_for(const MethodInput& in, std::uint32_t label) {
  return in.labels.empty() || std::find(in.labels.begin(), in.labels.end(), label) != in.labels.end();
}

// A polygon stack's slices as parallel sections (working pixels, normal +z;
// even-odd nesting as the stack).
ObjectSections polygon_stack_sections(const SliceStack& st) {
  ObjectSections o{1, 0, {}, 0};
  for (const Slice& s : st.slices) {
    Section sec;
    sec.pose.origin = Vec3d(0, 0, s.z);
    sec.source = s.source;
    for (const Polygon& p : s.polygons) sec.contours.push_back({p.points, o.label, false});
    o.sections.push_back(std::move(sec));
  }
  return o;
}

// Pixels [x0, x1) x [y0, y1) of the slices' images that the solver's box for
// label l can reach: the bounding box of l's loops over all slices, widened
// by kCropMargin of its diagonal (Field3dParams::margin's default) or `band_pad` pixels (the band margin,
// band_margin_mm()) if more, plus a pixel.
std::array<int, 4> object_crop(const std::vector<std::map<std::uint32_t, std::vector<std::vector<Vec2d>>>>& loops,
                               std::uint32_t l, const std::vector<Grid2u32>& images, double band_pad) {
  constexpr double kCropMargin = 0.2;  // twice field3d.margin's default: the box never reaches beyond
  Vec2d lo = Vec2d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  int w = 0, h = 0;
  for (std::size_t k = 0; k < loops.size(); ++k) {
    w = std::max(w, images[k].width);
    h = std::max(h, images[k].height);
    if (const auto it = loops[k].find(l); it != loops[k].end())
      for (const auto& loop : it->second)
        for (const Vec2d& p : loop) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  }
  const double pad = std::max(kCropMargin * (hi - lo).norm(), band_pad) + 1;
  return {std::max(0, int(std::floor(lo.x() - pad))), std::max(0, int(std::floor(lo.y() - pad))),
          std::min(w, int(std::ceil(hi.x() + pad)) + 1), std::min(h, int(std::ceil(hi.y() + pad)) + 1)};
}

// A mask or label stack's slices as label-image sections (working pixels,
// normal +z), each traced per label: one object per label (masks: one).
std::vector<ObjectSections> image_stack_sections(const MethodInput& in, const ReconstructParams& params) {
  const SliceStack& st = in.stack;
  if (st.kind == InputKind::Contours)
    throw ParamError(option_given("--method", "field3d") +
                     ": reads masks, label images, label volumes and drawn polygons; contour images need " +
                     option_given("--input", "masks") + " (filled regions) or another method");
  const bool labels = st.kind == InputKind::Labels;
  params_table<MaskCurveParams>().validate(params.mask_curve);
  const PixelBoundary boundary = pixel_boundary(params.field3d);
  // Per slice, per label: its boundary loops; the slice's labels (masks: 1 inside) when the solver keeps images.
  std::vector<std::map<std::uint32_t, std::vector<std::vector<Vec2d>>>> loops(st.slices.size());
  std::vector<Grid2u32> images(boundary.keep_image ? st.slices.size() : 0);
  tbb::parallel_for(std::size_t(0), st.slices.size(), [&](std::size_t k) {
    Slice s = st.slices[k];
    if (st.load_image) s.image = st.load_image(k);
    if (!labels) {
      const Grid2u8 inside = detail::slice_masks(st, s, params, 1).inside;
      loops[k][1] = boundary_loops(inside, params.mask_curve, boundary.sigma);
      if (boundary.keep_image) images[k] = Grid2u32(inside.width, inside.height, 0);
      for (std::size_t i = 0; boundary.keep_image && i < inside.size(); ++i) images[k].data[i] = inside.data[i] != 0;
      return;
    }
    if (boundary.keep_image) images[k] = s.image;
    std::vector<std::uint32_t> present(s.image.data.begin(), s.image.data.end());
    std::sort(present.begin(), present.end());
    present.erase(std::unique(present.begin(), present.end()), present.end());
    Grid2u8 inside(s.image.width, s.image.height, 0);
    for (const std::uint32_t l : present) {
      if (l == 0 || !asked_for(in, l)) continue;
      for (std::size_t i = 0; i < inside.size(); ++i) inside.data[i] = s.image.data[i] == l;
      loops[k][l] = boundary_loops(inside, params.mask_curve, boundary.sigma);
    }
  });
  std::map<std::uint32_t, ObjectSections> objects;
  for (const auto& per : loops)
    for (const auto& [l, ls] : per)
      if (!ls.empty()) objects.emplace(l, ObjectSections{l, labels ? l : 0, {}, 1.0});
  const Field3dParams pixel = pixel_rows(params.field3d);
  double band_pad = 0;
  if (pixel.band_margin > 0) {  // the slices' heights only: their gap
    std::vector<Section> planes(st.slices.size());
    for (std::size_t k = 0; k < st.slices.size(); ++k) planes[k].pose.origin = Vec3d(0, 0, st.slices[k].z);
    band_pad = band_margin_mm(pixel, 1 / kImageCellsPerPixel, detail::median_gap(planes));
  }
  for (auto& [l, o] : objects) {
    const std::array<int, 4> crop = boundary.keep_image ? object_crop(loops, l, images, band_pad) : std::array<int, 4>{};
    for (std::size_t k = 0; k < st.slices.size(); ++k) {
      Section sec;
      sec.pose.origin = Vec3d(0, 0, st.slices[k].z);
      sec.source = st.slices[k].source;
      if (const auto it = loops[k].find(l); it != loops[k].end())
        for (const auto& loop : it->second) sec.contours.push_back({loop, l, false});
      if (boundary.keep_image) {  // the object's crop: the solver's box holds no other pixel
        sec.pose.origin += Vec3d(crop[0], crop[1], 0);
        for (auto& c : sec.contours)
          for (Vec2d& p : c.points) p -= Vec2d(crop[0], crop[1]);
        sec.pixel_size = 1;
        sec.labels = Grid2u32(crop[2] - crop[0], crop[3] - crop[1], 0);
        for (int y = crop[1]; y < crop[3]; ++y)
          for (int x = crop[0]; x < crop[2]; ++x)
            if (x < images[k].width && y < images[k].height) sec.labels(x - crop[0], y - crop[1]) = images[k](x, y);
      }
      o.sections.push_back(std::move(sec));
    }
  }
  std::vector<ObjectSections> out;
  for (auto& [l, o] : objects) out.push_back(std::move(o));
  return out;
}

// Every label of a partition traced on each image section (polyline
// sections as they are): the partition solves every label from the same
// sections, and a label's neighbours bound it only where their contours are.
// The label image, when `boundary` keeps it, is carried once (the first
// label's traced section; the others add their contours).
std::vector<Section> partition_sections(const std::vector<Section>& sections, const std::vector<std::uint32_t>& labels,
                                        const MaskCurveParams& mask_curve, const PixelBoundary& boundary) {
  params_table<MaskCurveParams>().validate(mask_curve);
  std::vector<Section> out(sections.size());
  tbb::parallel_for(std::size_t(0), sections.size(), [&](std::size_t i) {
    if (!sections[i].is_image()) {
      out[i] = sections[i];
      return;
    }
    for (const std::uint32_t l : labels) {
      Section t = traced_section(sections[i], l, mask_curve, boundary);
      if (out[i].contours.empty()) out[i] = std::move(t);
      else out[i].contours.insert(out[i].contours.end(), t.contours.begin(), t.contours.end());
    }
  });
  return out;
}

// The objects the method reconstructs for one input: the reader's sections
// (label images traced), or the stack's slices as sections.
std::vector<ObjectSections> input_objects(const MethodInput& in, const ReconstructParams& params) {
  if (!in.sections.empty()) {
    const PixelBoundary boundary = pixel_boundary(params.field3d);
    ObjectSections o{in.section_label, in.section_label,
                     in.partition ? partition_sections(in.sections, in.partition->labels(), params.mask_curve, boundary)
                                  : traced_sections(in.sections, in.section_label, params.mask_curve, boundary),
                     0};
    double pixel = std::numeric_limits<double>::infinity();
    for (const Section& s : in.sections)
      if (s.is_image()) pixel = std::min(pixel, s.pixel_size);
    o.pixel = std::isfinite(pixel) ? pixel : 0.0;
    return {std::move(o)};
  }
  if (in.stack.has_polygons()) return {polygon_stack_sections(in.stack)};
  return image_stack_sections(in, params);
}

int sections_with_contours(const ObjectSections& o) {
  return int(std::count_if(o.sections.begin(), o.sections.end(), [&](const Section& s) {
    return std::any_of(s.contours.begin(), s.contours.end(), [&](const SectionContour& c) { return c.label == o.label; });
  }));
}

// The object's work for the budget (ReconstructOptions::on_estimate), before its grid is made.
void report_work(const MethodInput& in, const ObjectSections& o, const Field3dWork& w) {
  WorkEstimate e;
  e.label = o.object;
  e.slices = sections_with_contours(o);
  e.grid = {w.nx, w.ny, w.nz};
  e.samples = w.samples;
  e.triangles = w.triangles;
  e.field_bytes = w.solve_bytes;
  e.mesh_bytes = w.mesh_bytes;
  in.on_estimate(e);
}

// Every object's mesh (world units for sections, working pixels for a
// stack); no decimation (its bound is in the stack's pixels, which a CSL file
// does not have). Each object's work goes to in.on_estimate first.
ReconstructResult reconstruct_field3d(const MethodInput& in, const ReconstructParams& params) {
  params_table<ReconstructParams>().validate(params);
  ReconstructResult r;
  for (const ObjectSections& o : input_objects(in, params)) {
    ObjectResult ob;
    ob.label = o.object;
    if (in.partition && !in.sections.empty()) {  // the labels of one input as one partition (pixel cells per group)
      // The taker that solves carries the partition's peak; the others only their meshes.
      const auto before = [&](bool solves) {
        if (!in.on_estimate) return;
        Field3dWork w = estimate_partition(o.sections, in.partition->labels(), o.label, params.field3d, o.pixel);
        if (!solves) w.solve_bytes = 0;
        report_work(in, o, w);
      };
      Partition3dObject p = in.partition->take(o.sections, o.label, params.field3d, o.pixel, r.times.interp, before);
      ob.mesh = std::move(p.mesh);
      ob.check = p.check;
      ob.field3d = p.stats;
      for (auto& w : p.warnings) r.warnings.push_back(std::move(w));
    } else {
      const Field3dParams fp = o.pixel > 0 ? pixel_params(o.sections, o.label, o.pixel, params.field3d) : params.field3d;
      if (in.on_estimate) report_work(in, o, estimate_sections(o.sections, o.label, fp));
      Field3dResult f = reconstruct_sections(o.sections, o.label, fp);
      ob.mesh = std::move(f.mesh);
      ob.check = f.check;
      ob.field3d = solve_stats(f);
      r.times.interp += f.seconds;
      for (auto& w : f.warnings) r.warnings.push_back(std::move(w));
    }
    ob.triangles_before_decimation = long(ob.mesh.triangles.size());
    ob.slices_with_contours = sections_with_contours(o);
    if (ob.mesh.empty()) ob.empty_reason = "the field3d field never rises above zero (no inside anywhere)";
    r.objects.push_back(std::move(ob));
  }
  return r;
}

}  // namespace

MethodSpec field3d_method() {
  return {
      .name = "field3d",
      .doc = "one smooth 3D field from every drawn section in any orientation (bi-Laplacian energy, the in-plane "
             "distances on every plane; CSL, RT Structure Sets, polyline files, masks and labels traced to their "
             "sub-pixel boundary; docs/decisions.md)",
      .defaults = [](ReconstructParams&) {},
      .rows = {"field3d.", "mask_curve."},
      .fits_curves = false,
      .slice_field = {},
      .reconstruct = reconstruct_field3d,
      .reads_sections = true,
  };
}

}  // namespace isoloft
