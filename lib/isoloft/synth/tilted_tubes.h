// @file synth/tilted_tubes.h
// @brief The tilted-tube kit: thin structures that travel sideways
// between slices, and separate objects on neighbouring slices, with exact
// signed distances. Pixel units (x column, y row, z height); slice k lies at
// z = slice_z[k] and a pixel is inside if its centre is (as synthesize()).
// Sign convention: value() > 0 inside.
// Shapes: a tube set (a ball of radius r swept along polylines: tubes,
// forks, helices, capsules) with value r - distance to the polylines, exact
// outside and inside but near a fork's crease; a set of balls with value
// max_i (R_i - |p - c_i|), exact for disjoint balls.
// @warning Inside, near a fork's crease, value() exceeds the distance to the
// surface and closest_point() is a surface point, not the nearest one.
#pragma once

#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "isoloft/synth/shapes.h"
#include "isoloft/synth/synth.h"

namespace isoloft {

/// Empty pixels around every kit shape's image.
inline constexpr double kTiltedMargin = 8;

/// A kit case: its truth, where it is cut, and its true component count.
struct TiltedCase {
  std::string name;
  std::unique_ptr<Shape> shape;
  std::vector<double> slice_z;  ///< increasing, px
  int width = 0, height = 0;    ///< image size, px
  int components = 1;           ///< connected components of the solid
  nlohmann::json params;        ///< how it was made
};

/// Generic tilted-tube shapes, sized by these (`isoloft synth NAME --tilt ...`).
struct TiltedOptions {
  double tilt = 80;     ///< deg from the slice normal: a tube's axis, a fork's branches
  double radius = 3;    ///< px: the tube (the balls of two-spheres, the bars, the columns)
  double spacing = 8;   ///< px between slices
  int slices = 0;       ///< slices cut; 0: the shape's own count
  double gap = 4;       ///< px between the separate objects' cross-sections
};

/// tube, fork, helix, two-spheres, two-columns, two-bars-side, two-bars-end.
std::vector<std::string> tilted_shape_names();
/// \throw ParamError on an unknown name or options it cannot use.
TiltedCase make_tilted_shape(const std::string& name, const TiltedOptions& options);

/// The kit's named cases (tube80_r3_s8, ..., two_bars_end_s8): radius 2-5
/// px, tilt 45-85 deg, spacing 4-8 px, forks, helices, separate objects.
std::vector<std::string> tilted_kit_names();
/// \throw ParamError on an unknown name.
TiltedCase tilted_kit_case(const std::string& name);

/// The case cut at its slice_z into images (or polygons) of `kind`; the
/// description adds "components".
SynthResult synthesize(const TiltedCase& c, InputKind kind, double polyline_step = SynthParams{}.polyline_step);

/// A tube set or ball set from its JSON ({"type": "tubes"|"balls", ...}), or nullptr for another type.
/// \throw ParamError on missing fields.
std::unique_ptr<Shape> tilted_shape_from_json(const nlohmann::json& j);

// The kit's shapes one by one (tilted_tubes_kit.py of the research).
TiltedCase tilted_tube(double tilt_deg, double r, double spacing, int n_slices = 5, double azimuth_deg = 20);
TiltedCase tilted_fork(double r, double spacing, double branch_deg, int trunk_slices = 3, int branch_slices = 3,
                         double azimuth_deg = 20);
TiltedCase tilted_helix(double r, double coil_radius, double pitch, double spacing, double turns = 1.25);
TiltedCase two_spheres(double radius, double spacing, double gap, int n_slices = 4);
TiltedCase two_columns(double radius, double spacing, double gap, int per_column = 3);
TiltedCase two_bars(double radius, double length, double spacing, double gap, bool end_to_end, int n_slices = 4);

}  // namespace isoloft
