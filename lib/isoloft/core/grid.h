// @file core/grid.h
// @brief Dense row-major 2D grids (x fastest) and pixel boxes.
// Pixel-centre convention, used everywhere in isoloft: the value at (x, y)
// belongs to the centre of column x, row y, the point (x, y) in pixel units.
#pragma once

#include <cassert>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace isoloft {

template <class T>
struct Grid2 {
  int width = 0;
  int height = 0;
  std::vector<T> data;

  Grid2() = default;
  Grid2(int w, int h, T fill = T{}) : width(w), height(h), data(std::size_t(w) * std::size_t(h), fill) {}

  [[nodiscard]] bool contains(int x, int y) const { return x >= 0 && y >= 0 && x < width && y < height; }
  [[nodiscard]] std::size_t index(int x, int y) const { return std::size_t(y) * std::size_t(width) + std::size_t(x); }
  [[nodiscard]] std::size_t size() const { return data.size(); }
  [[nodiscard]] bool empty() const { return data.empty(); }

  T& operator()(int x, int y) {
    assert(contains(x, y));
    return data[index(x, y)];
  }
  const T& operator()(int x, int y) const {
    assert(contains(x, y));
    return data[index(x, y)];
  }
  bool operator==(const Grid2&) const = default;
};

using Grid2f = Grid2<float>;
using Grid2d = Grid2<double>;
using Grid2u8 = Grid2<std::uint8_t>;
using Grid2u32 = Grid2<std::uint32_t>;
using Grid2i = Grid2<std::int32_t>;

/// Axis-aligned pixel rectangle [x0, x1) x [y0, y1).
struct PixelBox {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  [[nodiscard]] bool empty() const { return x1 <= x0 || y1 <= y0; }
  [[nodiscard]] int width() const { return x1 - x0; }
  [[nodiscard]] int height() const { return y1 - y0; }
};

}  // namespace isoloft
