// @file methods/params.cpp
// @brief The parameter schema of reconstruct(): params_table<ReconstructParams>
// (one row per parameter: key, unit, doc, range, flag), JSON both ways, and
// the method defaults it starts from (methods/method.h).
#include <optional>
#include <string>
#include <vector>

#include "isoloft/core/error.h"
#include "isoloft/methods/method.h"
#include "isoloft/methods/params.h"

namespace isoloft {

namespace {
// The method and z scheme rows' docs: each registered one's own line.
template <class Spec>
std::string registry_doc(const std::vector<Spec>& specs, const std::string& what) {
  std::string doc;
  for (const Spec& s : specs) doc += (doc.empty() ? "" : "; ") + s.name + ": " + s.doc;
  return doc + "; " + what;
}
std::string method_doc() { return registry_doc(methods(), "picks the defaults of the other keys"); }
std::string z_scheme_doc() { return registry_doc(z_schemes(), "how the slice fields are interpolated in z (paper 2.4)"); }
}  // namespace

const Method Method::Isoloft{"isoloft"};
const Method Method::Marker2006{"marker2006"};
const Method Method::Levin{"levin"};
const Method Method::Field3d{"field3d"};

template <>
const ParamTable<ReconstructParams>& params_table<ReconstructParams>() {
  static const ParamTable<ReconstructParams> table = [] {
    using P = ReconstructParams;
    ParamTable<P>::Rows rows{
        name_field("method", &P::method, method_doc(), method_names()).cli("--method"),
        name_field("z_scheme", &P::z_scheme, z_scheme_doc(), z_scheme_names()).cli("--z-scheme"),
        field("binarize", &P::binarize, "",
              "threshold non-binary contour/mask images at half range instead of rejecting them")
            .cli("--binarize"),
        field("mask_edge_offset", &P::mask_edge_offset, "px",
              "marker2006, masks/labels: contour points move this far out along their normals, from the boundary pixel "
              "centres (paper 2.1) onto the mask's edge",
              between(-2, 2)),
        field("polyline_spacing", &P::polyline_spacing, "px",
              "marker2006, polylines: spacing of the contour points sampled along every polygon edge", between(0.01, 100)),
        field("polyline_raster_width", &P::polyline_raster_width, "px",
              "marker2006, polylines: fit on a raster this many pixels across, as the paper's pelvis (2000); 0 = fit the "
              "polygons directly",
              between(0, kMaxPolylineRaster))
            .cli("--raster-resolution"),
        field("sign_guard", &P::sign_guard, "px",
              "marker2006: pixels farther than this from every contour pixel keep the contour fill's inside/outside where "
              "the MPU sign disagrees (not in the paper); 0 = the pure MPU sign",
              at_least(0))
            .cli("--sign-guard"),
        field("mpu_band", &P::mpu_band, "px",
              "marker2006: the MPU curve is fitted and evaluated only within this distance of a contour pixel, where "
              "the narrow band needs it (paper 2.2); beyond it only the sign is needed and the contour fill gives it; 0 "
              "= fit and evaluate the whole crop box",
              Range{0.0, 1e4, false, false})
            .cli("--mpu-band"),
        field("mask_boundary", &P::mask_boundary, "",
              "masks/labels: traced (the smooth sub-pixel curve keeping every drawn pixel on its side, fitted exactly: "
              "the distance to it; not in the paper; mask_curve.*) or pixel-centres (the paper 2.1: boundary pixel "
              "centres moved mask_edge_offset out, the MPU fit)")
            .cli("--mask-boundary"),
        field("polyline_boundary", &P::polyline_boundary, "",
              "polylines: drawn (the polygons as drawn: the slice field is the exact distance to their edges, no fit; "
              "not in the paper) or fit (the paper 2.1: points along the edges, the MPU fit)")
            .cli("--polyline-boundary"),
        field("mask_min_feature", &P::mask_min_feature, "px",
              "marker2006, masks/labels: mask features (lines, spurs, islands; notches, holes, gaps) narrower than this "
              "are removed before the contour points are taken, by an opening and a closing with a square of this side "
              "(not in the paper); 1 = the mask as it is",
              between(1, 16)),
        field("label_partition", &P::label_partition, "",
              "labels: every label's field and the background's (minus the field of the labels' union) compete, each "
              "point going to the highest, so touching labels share their boundary and no point inside the union is "
              "left unlabelled (not in the paper); false: each label reconstructed on its own")
            .cli("--independent-labels", false),
        field("crop_margin", &P::crop_margin, "px",
              "each object is processed in the bounding box of its contours plus this margin (room for the filter's "
              "stencils)",
              at_least(1)),
    };
    std::vector<ParamTable<P>::Check> checks{[](const P& p, const std::string& at) {
      if (p.mpu_band > 0 && p.mpu_band < kMinMpuBand)
        throw ParamError(at + "mpu_band: must be 0 (the whole crop box) or at least " + std::to_string(kMinMpuBand) +
                         " px, got " + std::to_string(p.mpu_band));
      if (!(-p.interp.cap_depth <= double(p.mc.iso)))
        throw ParamError(at + "mc.iso: must be above -interp.cap_depth (" + std::to_string(-p.interp.cap_depth) +
                         ", the value outside the end caps), got " + std::to_string(p.mc.iso));
    }};
    ParamTable<P>::nest(rows, checks, "fill", &P::fill, params_table<FillParams>());
    ParamTable<P>::nest(rows, checks, "mask_curve", &P::mask_curve, params_table<MaskCurveParams>());
    ParamTable<P>::nest(rows, checks, "normals", &P::normals, params_table<NormalsParams>());
    ParamTable<P>::nest(rows, checks, "mpu", &P::mpu, params_table<MpuParams>());
    ParamTable<P>::nest(rows, checks, "band", &P::band, params_table<NarrowBandParams>());
    ParamTable<P>::nest(rows, checks, "extend", &P::extend, params_table<ExtendParams>());
    ParamTable<P>::nest(rows, checks, "filter", &P::filter, params_table<FilterParams>());
    ParamTable<P>::nest(rows, checks, "interp", &P::interp, params_table<InterpParams>());
    ParamTable<P>::nest(rows, checks, "track", &P::track, params_table<TrackParams>());
    ParamTable<P>::nest(rows, checks, "mc", &P::mc, params_table<MarchingCubesParams>());
    ParamTable<P>::nest(rows, checks, "decimate", &P::decimate, params_table<DecimateParams>());
    ParamTable<P>::nest(rows, checks, "field3d", &P::field3d, params_table<Field3dParams>());
    return ParamTable<P>(std::move(rows), std::move(checks));
  }();
  return table;
}

nlohmann::json params_to_json(const ReconstructParams& p) { return params_table<ReconstructParams>().to_json(p); }

ReconstructParams params_from_json(const nlohmann::json& j, const ReconstructParams& base) {
  return params_table<ReconstructParams>().from_json(j, base);
}

bool fits_curves(const Method& m) { return method_spec(m.name()).fits_curves; }

ReconstructParams method_defaults(const Method& m) {
  ReconstructParams p;
  method_spec(m.name()).defaults(p);
  p.method = m;
  return p;
}

ReconstructParams params_from_json(const nlohmann::json& j, std::optional<Method> method) {
  if (!method && j.is_object() && j.contains("method"))
    method = params_table<ReconstructParams>().from_json({{"method", j["method"]}}).method;
  ReconstructParams p = params_from_json(j, method_defaults(method.value_or(ReconstructParams{}.method)));
  if (method) p.method = *method;
  return p;
}

}  // namespace isoloft
