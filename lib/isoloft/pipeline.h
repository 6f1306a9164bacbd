// The reconstruction pipeline: wires the stages of Marker, Braude, Museth &
// Breen 2006 (or the Levin 1986-style baseline) and owns timing and progress.
// Stages know nothing of each other, only the core types.
//
//   slices -> contour pixels + inside (even-odd)      contour/   paper 2.1
//          -> [marker2006] normals, MPU curve        fit/       paper 2.1
//          -> signed distance field per slice         field/     paper 2.2
//          -> [marker2006] distance-dependent filter  field/     paper 2.3
//          -> z splines, slab by slab                 interp/    paper 2.4
//          -> Marching Cubes, decimation              mesh/      paper 2.5
//
// Every stage runs over all slices in parallel before the next starts, so
// per-stage wall times are well defined (the paper's Table 3 columns).
// Coordinates: pixel units of the working grid; pixel (i, j) of slice k is at
// (i, j, z_k). Field convention: signed distance, positive inside.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "isoloft/contour/fill.h"
#include "isoloft/contour/normals.h"
#include "isoloft/core/params.h"
#include "isoloft/field/filter.h"
#include "isoloft/field/marching.h"
#include "isoloft/field/narrow_band.h"
#include "isoloft/fit/mpu.h"
#include "isoloft/core/mesh.h"
#include "isoloft/core/slice_stack.h"
#include "isoloft/interp/spline.h"
#include "isoloft/mesh/decimate.h"
#include "isoloft/mesh/marching_cubes.h"
#include "isoloft/mesh/mesh_check.h"

namespace isoloft {

enum class Method {
  Marker2006,  ///< the paper: MPU curve, distance extension, filter
  Levin,       ///< baseline: exact EDT of the pixel contours (Levin 1986 style), no filter
};

inline constexpr std::array<EnumName<Method>, 2> kMethodNames{{{Method::Marker2006, "marker2006"}, {Method::Levin, "levin"}}};
constexpr std::span<const EnumName<Method>> enum_names(Method) { return kMethodNames; }

/// All parameters of a reconstruction: a few of the pipeline's own, then one
/// struct per stage. Every field is a row of params_table<ReconstructParams>()
/// (below), with its unit, range and doc.
struct ReconstructParams {
  Method method = Method::Marker2006;
  bool binarize = false;
  double mask_edge_offset = 0.5;
  double polyline_spacing = 0.5;
  int polyline_raster_width = 0;
  double sign_guard = 2.0;
  double mpu_band = 4.0;
  int mask_min_feature = 2;
  int crop_margin = 32;
  FillParams fill;              ///< contour/: even-odd fill, open contours
  NormalsParams normals;        ///< contour/: paper 2.1
  MpuParams mpu;                ///< fit/: paper 2.1
  NarrowBandParams band;        ///< field/: paper 2.2
  ExtendParams extend;          ///< field/: paper 2.2
  FilterParams filter;          ///< field/: paper 2.3
  InterpParams interp;          ///< interp/: paper 2.4
  MarchingCubesParams mc;       ///< mesh/: paper 2.5
  DecimateParams decimate;      ///< mesh/: paper 2.5
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
  // Seconds of wall time, summed over objects.
  double contour = 0, mpu = 0, dist = 0, filter = 0, interp = 0, mesh = 0, decimate = 0;
  [[nodiscard]] double total() const { return contour + mpu + dist + filter + interp + mesh + decimate; }
};

struct ObjectResult {
  std::uint32_t label = 0;     ///< label value (labels input); 0 otherwise
  TriMesh mesh;                ///< closed, outward-oriented, pixel units
  MeshCheck check;
  long triangles_before_decimation = 0;
  int slices_with_contours = 0;
  FitStats fit;                ///< marker2006: summed over slices
  PixelBox box;                ///< cropped working region
};

/// One slice's intermediate fields (marker2006), for figures (--dump-stages).
struct SliceStageFields {
  std::uint32_t label = 0;
  int slice = 0;
  PixelBox box;                 ///< where the crop sits in the slice
  OrientedPoints points;        ///< contour points and outward normals (crop coordinates)
  Grid2f mpu;                   ///< MPU function f (positive inside)
  Grid2f distance;              ///< signed Euclidean distance (narrow band + extension)
  Grid2f filtered;              ///< after the distance-dependent filter
};

struct ReconstructOptions {
  std::vector<std::uint32_t> labels;  ///< labels input: only these (empty = all); an error with other inputs
  /// Called once per slice with its intermediate fields (marker2006 only),
  /// from worker threads (serialize inside if needed).
  std::function<void(const SliceStageFields&)> on_slice_fields;
  /// Receives every sampled z plane of each object's interpolated field
  /// (padded crop, with its x0/y0 origin): used to write --volume.
  std::function<void(std::uint32_t label, const Grid2f& plane, double x0, double y0, double z, int plane_index, int plane_count)> on_plane;
  /// Progress: stage name, items done, items total.
  std::function<void(const std::string&, long, long)> progress;
};

struct ReconstructResult {
  std::vector<ObjectResult> objects;
  StageTimes times;
  std::vector<std::string> warnings;
};

/// Reconstructs one closed surface per object of the stack: one object, or
/// one per label with InputKind::Labels (paper 2.1-2.5; the stages in
/// pipeline.cpp).
/// \pre stack has >= 2 slices with strictly increasing z, all of one size.
/// \throw InputError naming the slice file for unusable slices (non-binary
///        values in contours/masks mode, open contours with FillParams policy
///        Error); ParamError naming the parameter for bad parameters.
ReconstructResult reconstruct(const SliceStack& stack, const ReconstructParams& params, const ReconstructOptions& options = {});

/// Parameters as JSON (every field) and back: params_table<ReconstructParams>().
/// from_json starts from `base` and applies only the keys present.
/// \throw ParamError naming an unknown key, a wrong type or a value out of range.
nlohmann::json params_to_json(const ReconstructParams&);
ReconstructParams params_from_json(const nlohmann::json&, const ReconstructParams& base = {});

}  // namespace isoloft
