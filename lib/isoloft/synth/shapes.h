// @file synth/shapes.h
// @brief Analytic test shapes, in pixel units (x column, y row, z slice).
// Sign convention: value() > 0 inside; the exact signed distance if exact()
// (sphere, torus), else a smooth implicit with the same zero set.
#pragma once

#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "isoloft/core/mesh.h"

namespace isoloft {

class Shape {
 public:
  virtual ~Shape() = default;
  /// > 0 inside: the signed distance if exact(), else |grad| ~ 1 near the surface.
  [[nodiscard]] virtual double value(const Vec3d& p) const = 0;
  [[nodiscard]] virtual bool exact() const = 0;
  [[nodiscard]] virtual nlohmann::json to_json() const = 0;
  /// {min, max} of the solid.
  [[nodiscard]] virtual std::array<Vec3d, 2> bounds() const = 0;
  /// Outward unit normal -grad / |grad|.
  [[nodiscard]] virtual Vec3d normal(const Vec3d& p) const;
  /// Closest surface point: exact, or Newton steps along the gradient (~1e-9 px).
  [[nodiscard]] virtual Vec3d closest_point(const Vec3d& p) const;
  [[nodiscard]] double distance(const Vec3d& p) const { return (closest_point(p) - p).norm(); }
  [[nodiscard]] virtual std::unique_ptr<Shape> translated(const Vec3d& t) const = 0;
};

/// Shape from its JSON description ({"type": "sphere", ...} as written by to_json()).
/// \throw ParamError on an unknown type or missing fields.
std::unique_ptr<Shape> shape_from_json(const nlohmann::json& j);

/// Names accepted by make_default_shape().
std::vector<std::string> shape_names();

/// A shape sized for a `size`^2 image, centred in x and y, z in [0, depth]:
/// sphere, ellipsoid, torus (axis z: nested contours), tilted-torus (60
/// degrees: slices in two pieces), branching-cylinders (a blended Y of three
/// capsules), two-blobs. \throw ParamError on an unknown name.
std::unique_ptr<Shape> make_default_shape(const std::string& name, int size);

}  // namespace isoloft
