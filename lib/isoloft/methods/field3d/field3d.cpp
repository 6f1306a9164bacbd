// @file methods/field3d/field3d.cpp
// @brief field3d: one smooth 3D field constrained by every drawn section, in
// any orientation (the solver: field3d/field3d.h). It reads sections, not
// slices: a CSL file's sections, or a polygon stack's slices as parallel
// sections; it has no per-slice field, so it is a family of its own
// (MethodSpec::reconstruct).
#include <algorithm>

#include "isoloft/core/error.h"
#include "isoloft/core/option_names.h"
#include "isoloft/field3d/partition3d.h"
#include "isoloft/methods/method.h"
#include "isoloft/methods/params.h"

namespace isoloft {

namespace {

// The sections the method reads for one input, and the label it
// reconstructs: the reader's own sections, or a polygon stack's slices as
// parallel sections (working pixels, normal +z; even-odd nesting as the stack).
std::vector<Section> input_sections(const MethodInput& in, std::uint32_t& label) {
  if (!in.sections.empty()) {
    label = in.section_label;
    return in.sections;
  }
  const SliceStack& st = in.stack;
  if (!st.has_polygons())
    throw ParamError(option_given("--method", "field3d") +
                     ": reads drawn polygons (CSL, RT Structure Sets, polyline files); image and volume input "
                     "need another method");
  label = 1;
  std::vector<Section> out;
  for (const Slice& s : st.slices) {
    Section sec;
    sec.pose.origin = Vec3d(0, 0, s.z);
    sec.source = s.source;
    for (const Polygon& p : s.polygons) sec.contours.push_back({p.points, label, false});
    out.push_back(std::move(sec));
  }
  return out;
}

// Its mesh as the one object (world units for CSL, working pixels for a
// stack); no decimation (its bound is in the stack's pixels, which a CSL file
// does not have).
ReconstructResult reconstruct_field3d(const MethodInput& in, const ReconstructParams& params) {
  params_table<ReconstructParams>().validate(params);
  std::uint32_t label = 0;
  const std::vector<Section> sections = input_sections(in, label);
  ReconstructResult r;
  ObjectResult ob;
  if (in.partition && !in.sections.empty()) {  // the labels of one file as one partition
    Partition3dObject p = in.partition->take(sections, label, params.field3d, r.times.interp);
    ob.mesh = std::move(p.mesh);
    ob.check = p.check;
    r.warnings = std::move(p.warnings);
  } else {
    Field3dResult f = reconstruct_sections(sections, label, params.field3d);
    ob.mesh = std::move(f.mesh);
    ob.check = f.check;
    r.times.interp = f.seconds;
    r.warnings = std::move(f.warnings);
  }
  ob.triangles_before_decimation = long(ob.mesh.triangles.size());
  ob.slices_with_contours = int(std::count_if(sections.begin(), sections.end(), [&](const Section& s) {
    return std::any_of(s.contours.begin(), s.contours.end(), [&](const SectionContour& c) { return c.label == label; });
  }));
  if (ob.mesh.empty()) ob.empty_reason = "the field3d field never rises above zero (no inside anywhere)";
  r.objects.push_back(std::move(ob));
  return r;
}

}  // namespace

MethodSpec field3d_method() {
  return {
      .name = "field3d",
      .doc = "one smooth 3D field from every drawn section in any orientation (bi-Laplacian energy, the in-plane "
             "distances on every plane; CSL, RT Structure Sets and polyline files; docs/decisions.md)",
      .defaults = [](ReconstructParams&) {},
      .rows = {"field3d."},
      .fits_curves = false,
      .slice_field = {},
      .reconstruct = reconstruct_field3d,
      .reads_sections = true,
  };
}

}  // namespace isoloft
