// @file pipeline.h
// @brief reconstruct(): one closed surface per object of a slice stack.
// Marker, Braude, Museth & Breen 2006, or the Levin 1986-style baseline:
// contour and inside (paper 2.1), [marker2006] normals and MPU (2.1), signed
// distance (2.2), [marker2006] filter (2.3), z splines (2.4), Marching Cubes
// and decimation (2.5); per-slice ones in pipeline/slice_fields.h. A first
// pass makes every slice's masks (kept packed, O(contour length) bytes) and
// the crop box; then the slices are streamed: a window of them computed in
// parallel, the z splines through a window of knots (interp/z_stream.h), each
// plane meshed and dropped, so the fields held do not grow with the slice
// count (lazy images: SliceStack::load_image). Stage times split the streamed
// wall time by CPU shares. Each object runs in its
// crop box; pixel (i, j) of slice k is at (i, j, z_k). Sign convention:
// positive inside.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "isoloft/contour/fill.h"
#include "isoloft/contour/mask_curve.h"
#include <optional>

#include "isoloft/contour/normals.h"
#include "isoloft/core/params.h"
#include "isoloft/field/filter.h"
#include "isoloft/field/marching.h"
#include "isoloft/field/narrow_band.h"
#include "isoloft/field3d/field3d.h"
#include "isoloft/fit/mpu.h"
#include "isoloft/core/mesh.h"
#include "isoloft/core/slice_stack.h"
#include "isoloft/interp/spline.h"
#include "isoloft/interp/track_params.h"
#include "isoloft/mesh/decimate.h"
#include "isoloft/mesh/marching_cubes.h"
#include "isoloft/eval/point_mesh.h"
#include "isoloft/mesh/mesh_check.h"

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
/// of params_table<ReconstructParams>() (pipeline/params.cpp).
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

template <>
const ParamTable<ReconstructParams>& params_table<ReconstructParams>();

struct FitStats {
  long points = 0, leaves = 0, leaves_over_tol = 0;
  long fallback_slices = 0;    ///< slices with too few points for a curve (exact pixel distances used)
  long sign_guarded_pixels = 0;  ///< pixels whose MPU sign the sign guard overruled (ReconstructParams::sign_guard)
  long sign_guarded_slices = 0;  ///< slices with at least one such pixel
  int max_depth_reached = 0;
  double max_local_error = 0;  ///< px (Taubin distance)
};

struct StageTimes {
  // Wall seconds, summed over objects (objects run side by side: their sum
  // can exceed the run's wall time).
  double contour = 0, mpu = 0, dist = 0, filter = 0, interp = 0, mesh = 0, decimate = 0;
  [[nodiscard]] double total() const { return contour + mpu + dist + filter + interp + mesh + decimate; }
  StageTimes& operator+=(const StageTimes& o) {
    contour += o.contour, mpu += o.mpu, dist += o.dist, filter += o.filter;
    interp += o.interp, mesh += o.mesh, decimate += o.decimate;
    return *this;
  }
};

struct ObjectResult {
  std::uint32_t label = 0;     ///< label value (labels input); 0 otherwise
  TriMesh mesh;                ///< closed, outward-oriented, pixel units (possibly empty: empty_reason)
  std::string empty_reason;    ///< why the mesh has no triangles ("" if it has some)
  MeshCheck check;
  /// run_jobs(), RT Structure Set ROIs: how far the input's contour vertices
  /// lie from the mesh (working pixels): the geometric error of the working
  /// grid the reader chose.
  std::optional<DistanceSummary> contour_distance;
  long triangles_before_decimation = 0;
  int slices_with_contours = 0;
  FitStats fit;                ///< marker2006: summed over slices
  PixelBox box;                ///< cropped working region
  /// Most per-slice fields held at once: slices in flight, fields kept for an
  /// empty neighbour, spline knots and tangents (bounded by the window unless
  /// the natural spline or an empty slice needs more; docs/decisions.md).
  long peak_resident_fields = 0;
};

/// One slice's intermediate fields (marker2006), for --dump-stages.
struct SliceStageFields {
  std::uint32_t label = 0;
  int slice = 0;
  PixelBox box;                 ///< where the crop sits in the slice
  OrientedPoints points;        ///< contour points and outward normals (crop coordinates)
  Grid2f mpu;                   ///< MPU function f (positive inside)
  Grid2f distance;              ///< signed Euclidean distance (narrow band + extension)
  Grid2f filtered;              ///< after the distance-dependent filter
};

/// One object's cost, known after its contour stage and before any fit, for
/// a budget check (ReconstructOptions::on_estimate). Estimates, not bounds:
/// docs/decisions.md (work budget) has their measured accuracy.
struct WorkEstimate {
  std::uint32_t label = 0;
  PixelBox box;             ///< the crop of every field
  long slices = 0;          ///< input slices (the fields add 2 end caps)
  double planes = 0;        ///< z planes sampled for Marching Cubes
  double triangles = 0;     ///< Marching Cubes triangles before decimation
  double field_bytes = 0;   ///< per-slice fields, spline and fine rasters in flight
  double mesh_bytes = 0;    ///< the mesh before decimation and its checks
  double plane_bytes = 0;   ///< one sampled plane (float, padded crop), e.g. of --volume
};

struct ReconstructOptions {
  /// Per object after its contour stage, before the fit; may throw to stop
  /// the run (e.g. over a memory budget).
  std::function<void(const WorkEstimate&)> on_estimate;
  std::vector<std::uint32_t> labels;  ///< labels input: only these (empty = all); an error with other inputs
  /// Per slice (marker2006), from worker threads.
  std::function<void(const SliceStageFields&)> on_slice_fields;
  /// Every sampled plane of each object's field (padded crop), e.g. for --volume.
  std::function<void(std::uint32_t label, const Grid2f& plane, double x0, double y0, double z, int plane_index, int plane_count)> on_plane;
  /// Heights (working z, pixels) at which each object's interpolated field is
  /// wanted whole, e.g. every voxel slice for a dense label map; those within
  /// the object's z range (cap slices included) reach on_sample.
  std::vector<double> sample_z;
  /// Each object's field over its crop box at every sample_z it reaches.
  std::function<void(std::uint32_t label, const Grid2f& field, const PixelBox& box, double z)> on_sample;
  /// The object's label (0: the only object, or the label scan shared by
  /// every label), stage name, items done, items total; from worker threads.
  std::function<void(std::uint32_t label, const std::string& stage, long done, long total)> progress;
  /// Every slice field computed over the whole crop box, not only where it
  /// can reach the mesh (the same mesh bit for bit; pipeline/field_band.h).
  bool whole_fields = false;
};

struct ReconstructResult {
  std::vector<ObjectResult> objects;
  StageTimes times;
  std::vector<std::string> warnings;
};

/// True for the methods that fit curves (MethodSpec::fits_curves: isoloft, marker2006).
/// \throw ParamError for a method not registered.
bool fits_curves(const Method& m);

/// A method's parameters: ReconstructParams{} (the default method's:
/// the extremum-preserving z spline, slab end caps) with what the method's
/// spec changes (MethodSpec::defaults: marker2006 and levin take Hyman's z
/// spline and dome caps; docs/decisions.md: the isoloft method, end caps).
/// \throw ParamError for a method not registered.
ReconstructParams method_defaults(const Method& m);

/// Reconstructs one object, or one per label with InputKind::Labels.
/// \throw InputError for < 2 slices, z not increasing, slices (end caps
///        included) thinner than one interp.z_step, an empty image size,
///        non-binary contour/mask values or a rejected open contour (naming the
///        slice file); ParamError naming a parameter, or for labels without labels input.
/// @warning An object without inside, or a selected label found nowhere, is
/// skipped with a warning; empty slices close the object like end caps.
/// @warning marker2006: a slice of < kMinMpuPoints points keeps its pixel
/// distances, with a warning.
ReconstructResult reconstruct(const SliceStack& stack, const ReconstructParams& params, const ReconstructOptions& options = {});

/// Parameters as JSON and back; from_json applies the keys present to `base`.
/// \throw ParamError naming a bad key, type or value.
nlohmann::json params_to_json(const ReconstructParams&);
ReconstructParams params_from_json(const nlohmann::json&, const ReconstructParams& base);
/// The keys present applied to method_defaults() of j's "method" (or of
/// `method` if given, e.g. from a flag; else the default method's).
ReconstructParams params_from_json(const nlohmann::json& j, std::optional<Method> method = std::nullopt);

}  // namespace isoloft
