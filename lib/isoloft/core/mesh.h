// @file core/mesh.h
// @brief Indexed triangle mesh: Marching Cubes -> decimation -> metrics, writers.
// Pixel units of the working grid (x column, y row, z slice position) until io/.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

namespace isoloft {

using Vec2d = Eigen::Vector2d;
using Vec3d = Eigen::Vector3d;
using Vec3f = Eigen::Vector3f;

struct TriMesh {
  std::vector<Vec3f> vertices;
  std::vector<std::array<std::int32_t, 3>> triangles;  ///< counter-clockwise seen from outside
  [[nodiscard]] bool empty() const { return triangles.empty(); }
};

/// 8-bit RGB colour, e.g. per label in a combined mesh.
struct Rgb {
  std::uint8_t r = 0, g = 0, b = 0;
  bool operator==(const Rgb&) const = default;
};

}  // namespace isoloft
