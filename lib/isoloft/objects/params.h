// @file objects/params.h
// @brief ReconstructParams: the pipeline's own parameters, then one struct
// per stage, and the method by name (Method) with the boundary choices of the
// curve-fitting methods. The rows of params_table<ReconstructParams>() (docs,
// ranges, flags) and the method defaults are in methods/params.h.
#pragma once

#include <array>
#include <span>
#include <string>
#include <utility>

#include "isoloft/contour/fill.h"
#include "isoloft/contour/mask_curve.h"
#include "isoloft/contour/normals.h"
#include "isoloft/core/params.h"
#include "isoloft/field/filter.h"
#include "isoloft/field/marching.h"
#include "isoloft/field/narrow_band.h"
#include "isoloft/field3d/field3d.h"
#include "isoloft/fit/mpu.h"
#include "isoloft/interp/spline.h"
#include "isoloft/interp/track_params.h"
#include "isoloft/mesh/decimate.h"
#include "isoloft/mesh/marching_cubes.h"

namespace isoloft {

/// A reconstruction method by its registered name (methods/method.h: how each
/// slice becomes a field; registry.cpp lists them). The built-in ones are
/// named below for code that picks one; a method needs no name here.
class Method {
 public:
  Method() = default;  ///< the default method
  explicit Method(std::string name) : name_(std::move(name)) {}
  [[nodiscard]] const std::string& name() const { return name_; }
  friend bool operator==(const Method&, const Method&) = default;

  static const Method Isoloft;     ///< the default: marker2006 with the departures its spec names (each measured)
  static const Method Marker2006;  ///< the paper: MPU curve, distance extension, filter, Hyman's monotone z spline
  static const Method Levin;       ///< baseline: exact EDT of the pixel contours (Levin 1986 style), no filter
  static const Method Field3d;     ///< one 3D field from every section, any orientation (field3d/field3d.h)

 private:
  std::string name_ = "isoloft";
};
inline const std::string& to_string(const Method& method) { return method.name(); }

/// Where the contour of a mask or label slice comes from (curve-fitting methods).
enum class MaskBoundary {
  PixelCentres,  ///< the paper's: boundary pixel centres moved mask_edge_offset along their normals, then the MPU fit
  Traced,        ///< contour/mask_curve.h: the smooth sub-pixel curve that keeps every drawn pixel on its side
};
inline constexpr std::array<EnumName<MaskBoundary>, 2> kMaskBoundaryNames{
    {{MaskBoundary::PixelCentres, "pixel-centres"}, {MaskBoundary::Traced, "traced"}}};
constexpr std::span<const EnumName<MaskBoundary>> enum_names(MaskBoundary) { return kMaskBoundaryNames; }

/// Where the slice curve of polygon input comes from (curve-fitting methods).
enum class PolylineBoundary {
  Fit,    ///< the paper's: points sampled along the edges (polyline_spacing), the MPU fit
  Drawn,  ///< field/narrow_band.h polygon_narrow_band: the polygons themselves, the exact distance to their edges
};
inline constexpr std::array<EnumName<PolylineBoundary>, 2> kPolylineBoundaryNames{
    {{PolylineBoundary::Fit, "fit"}, {PolylineBoundary::Drawn, "drawn"}}};
constexpr std::span<const EnumName<PolylineBoundary>> enum_names(PolylineBoundary) { return kPolylineBoundaryNames; }

/// The pipeline's own parameters, then one struct per stage; docs in the rows
/// of params_table<ReconstructParams>() (methods/params.cpp).
struct ReconstructParams {
  Method method;                   ///< methods/method.h
  std::string z_scheme = "columns";  ///< methods/method.h: how the slice fields are interpolated in z
  bool binarize = false;
  double mask_edge_offset = 0.5;
  double polyline_spacing = 0.5;
  int polyline_raster_width = 0;
  double sign_guard = 2.0;
  double mpu_band = 4.0;
  int mask_min_feature = 2;
  MaskBoundary mask_boundary = MaskBoundary::Traced;  ///< the isoloft method's; marker2006: pixel-centres
  PolylineBoundary polyline_boundary = PolylineBoundary::Drawn;  ///< the isoloft method's; marker2006: fit
  int crop_margin = 32;
  bool label_partition = true;
  FillParams fill;              ///< contour/: even-odd fill, open contours
  NormalsParams normals;        ///< contour/: paper 2.1
  MpuParams mpu;                ///< fit/: paper 2.1
  NarrowBandParams band;        ///< field/: paper 2.2
  ExtendParams extend;          ///< field/: paper 2.2
  FilterParams filter;          ///< field/: paper 2.3
  MaskCurveParams mask_curve;    ///< contour/: the traced mask boundary
  /// interp/: paper 2.4 (spline, planes and end caps: isoloft's)
  InterpParams interp{.spline = SplineKind::ExtremumPreserving, .cap_shape = CapShape::Slab, .planes_on_slices = true};
  TrackParams track;            ///< interp/track.h: the track z scheme
  MarchingCubesParams mc;       ///< mesh/: paper 2.5
  DecimateParams decimate;      ///< mesh/: paper 2.5
  Field3dParams field3d;        ///< field3d/: the field3d method (sections in any orientation)
};

/// Least non-zero ReconstructParams::mpu_band, px: the fitted curve lies within
/// about tol + pixel_slack (1.25 px at the defaults) of the contour points, which
/// lie within 0.5 px of the contour pixels; the band must hold it and the pixel
/// beyond, where marching squares sees the sign change.
inline constexpr double kMinMpuBand = 2.0;

/// Largest fine raster for polylines, pixels across (the paper's pelvis used 2000).
inline constexpr int kMaxPolylineRaster = 20000;

}  // namespace isoloft
