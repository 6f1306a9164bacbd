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
std::string to_string(Method);
/// \throw ParamError for an unknown name ("marker2006", "levin").
Method method_from_string(const std::string&);
std::string to_string(InputKind);
/// \throw ParamError for an unknown name ("contours", "masks", "labels").
InputKind input_kind_from_string(const std::string&);

/// All parameters of a reconstruction, one struct per stage.
struct ReconstructParams {
  Method method = Method::Marker2006;
  InputKind input = InputKind::Contours;
  /// Threshold non-binary contour/mask images at half range instead of
  /// rejecting them (e.g. anti-aliased drawings).
  bool binarize = false;
  FillParams fill;              ///< contour/: even-odd fill, open contours (foundation)
  NormalsParams normals;        ///< contour/: paper 2.1, normals from the smoothed filled mask
  MpuParams mpu;                ///< fit/: paper 2.1, 2D MPU implicit curve
  NarrowBandParams band;        ///< field/: paper 2.2, exact distances near the MPU curve
  ExtendParams extend;          ///< field/: paper 2.2, extension to the whole grid
  FilterParams filter;          ///< field/: paper 2.3, distance-dependent Gaussian filter
  /// marker2006 with masks/labels input: contour points are the mask's
  /// boundary pixel centres (paper 2.1), which lie half a pixel inside the
  /// mask's edge; they are moved this far along their outward normals so the
  /// surface lies on the edge, as with the Levin mask path (pixels; 0 = the
  /// paper's boundary pixel centres).
  double mask_edge_offset = 0.5;
  /// marker2006 with polyline input: contour points sampled along every
  /// polygon edge at this spacing (pixels), normals from the polygons.
  double polyline_spacing = 0.5;
  /// marker2006 with polyline input: 0 fits the polygons directly; N > 0
  /// rasterizes them at N pixels across the slice width (the paper fitted its
  /// pelvis contours at 2000x2000 and continued at 500x500), fits the MPU
  /// curve to those contour pixels, and resamples it onto the working grid.
  int polyline_raster_width = 0;
  /// marker2006: pixels farther than this from every contour pixel of the
  /// working grid take their inside/outside from the contour fill (the
  /// input's own exact answer there) where the MPU sign disagrees. MPU
  /// extrapolates each local quadratic over its grown support, and on thin
  /// features (a sliver whose two sides fit one strip-shaped conic) the
  /// blend can stay positive far from any data; the fitted curve itself lies
  /// within tol + mask_edge_offset (1.25 px) of the contour pixels, so 2 px
  /// never touches it. Pixels, 0 = off (the pure MPU sign, paper 2.1).
  double sign_guard = 2.0;
  InterpParams interp;          ///< interp/: paper 2.4
  MarchingCubesParams mc;       ///< mesh/: paper 2.5
  DecimateParams decimate;      ///< mesh/: paper 2.5 (quadric error decimation)
  /// Each object is processed inside the bounding box of its contours plus
  /// this margin (pixels); large enough for the filter's stencils
  /// (d_max + 3 sigma_max = 24 px at the paper's values).
  int crop_margin = 32;
};

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
  std::vector<std::uint32_t> labels;  ///< labels input: only these (empty = all)
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

/// Reconstructs one closed surface per object of the stack (one object, or
/// one per label with InputKind::Labels).
/// \pre stack has >= 2 slices with strictly increasing z, all of one size.
/// \throw InputError naming the slice file for unusable slices (non-binary
///        values in contours/masks mode, open contours with FillParams policy
///        Error); ParamError for bad parameters.
ReconstructResult reconstruct(const SliceStack& stack, const ReconstructParams& params, const ReconstructOptions& options = {});

/// Parameters as JSON (every field, with defaults) and back. from_json starts
/// from `base` and overrides only the keys present.
/// \throw ParamError naming an unknown key or a value of the wrong type.
nlohmann::json params_to_json(const ReconstructParams&);
ReconstructParams params_from_json(const nlohmann::json&, const ReconstructParams& base = {});

namespace detail {
/// Distinct non-zero values of all slice images, sorted.
std::vector<std::uint32_t> distinct_labels(const SliceStack& stack);
/// Gives every empty slice (empty grid) a field: next to a non-empty slice,
/// that slice's field lowered by (max + cap_depth) / cap_extent, so the object
/// closes in the gap like an end cap; otherwise the most negative value.
void fill_empty_slices(std::vector<Grid2f>& fields, const PixelBox& box, const InterpParams& interp);
/// Sample positions of the Marching Cubes planes between the cap slices.
std::vector<double> sample_planes(double z_begin, double z_end, double step);
}  // namespace detail

}  // namespace isoloft
