// @file test_names.h
// @brief How a failing comparison names its element (libigl's test_common.h
// style): "pixel (x, y)", "point (x, y)". One definition for every test
// source, so the unity batches of the test runner see each name once.
#pragma once

#include <string>

#include "isoloft/core/mesh.h"

namespace isoloft {

inline std::string pixel_at(int x, int y) { return "pixel (" + std::to_string(x) + ", " + std::to_string(y) + ")"; }

inline std::string point_at(const Vec2d& p) {
  return "point (" + std::to_string(p.x()) + ", " + std::to_string(p.y()) + ")";
}

}  // namespace isoloft
