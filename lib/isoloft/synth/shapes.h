// Analytic test shapes with known surfaces, in pixel units of the working grid
// (x = column, y = row, z = slice position). value() is positive inside; it is
// the exact signed distance for sphere and torus, a smooth implicit with the
// same zero set for the others (closest points then come from projection).
// Shared by `isoloft synth`, `isoloft eval`, the tests and the experiments.
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
  /// Signed distance (exact() == true) or a smooth implicit with |grad| ~ 1 near the surface; > 0 inside.
  [[nodiscard]] virtual double value(const Vec3d& p) const = 0;
  [[nodiscard]] virtual bool exact() const = 0;
  [[nodiscard]] virtual nlohmann::json to_json() const = 0;
  /// Axis-aligned bounds of the solid: {min, max}.
  [[nodiscard]] virtual std::array<Vec3d, 2> bounds() const = 0;
  /// Outward unit normal direction at (or near) the surface: -grad(value)/|grad|.
  [[nodiscard]] virtual Vec3d normal(const Vec3d& p) const;
  /// Closest surface point: exact shapes override; others project by Newton
  /// steps along the gradient (accurate to ~1e-9 px near the surface).
  [[nodiscard]] virtual Vec3d closest_point(const Vec3d& p) const;
  /// Unsigned distance to the surface.
  [[nodiscard]] double distance(const Vec3d& p) const { return (closest_point(p) - p).norm(); }
  /// Same shape moved by t.
  [[nodiscard]] virtual std::unique_ptr<Shape> translated(const Vec3d& t) const = 0;
};

/// Shape from its JSON description ({"type": "sphere", ...} as written by to_json()).
/// \throw ParamError on an unknown type or missing fields.
std::unique_ptr<Shape> shape_from_json(const nlohmann::json& j);

/// Names accepted by make_default_shape().
std::vector<std::string> shape_names();

/// A shape of the given kind sized for an image of `size` x `size` pixels,
/// centred in x and y, with z in [0, depth] where depth is returned by bounds().
/// Kinds: sphere, ellipsoid, torus (axis along z: slices show nested
/// contours), tilted-torus (axis tilted 60 degrees: slices split into two
/// components), branching-cylinders (a Y of three capsules, smoothly blended),
/// two-blobs (two spheres blended into one body).
/// \throw ParamError on an unknown name.
std::unique_ptr<Shape> make_default_shape(const std::string& name, int size);

}  // namespace isoloft
