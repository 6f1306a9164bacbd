// @file io/volume.h
// @brief A dense 3D scalar volume, as read from NRRD / MetaImage.
// Sample (i, j, k) at origin + (i sx, j sy, k sz), physical units.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "isoloft/core/grid.h"

namespace isoloft {

struct Volume {
  int nx = 0, ny = 0, nz = 0;
  std::array<double, 3> spacing{1.0, 1.0, 1.0};  ///< physical size of a voxel along x, y, z
  std::array<double, 3> origin{0.0, 0.0, 0.0};   ///< physical position of voxel (0, 0, 0)'s centre
  std::vector<float> data;                       ///< x fastest, then y, then z; size nx*ny*nz

  [[nodiscard]] std::size_t index(int x, int y, int z) const {
    return (std::size_t(z) * std::size_t(ny) + std::size_t(y)) * std::size_t(nx) + std::size_t(x);
  }
  [[nodiscard]] float at(int x, int y, int z) const { return data[index(x, y, z)]; }
  [[nodiscard]] Grid2f plane(int z) const;
};

namespace detail {

/// Element types of both readers.
enum class ScalarType { U8, I8, U16, I16, U32, I32, F32, F64 };

std::size_t scalar_size(ScalarType t);

/// count elements of type t (either byte order) to floats. \pre src, dst hold them.
void decode_scalars(const unsigned char* src, std::size_t count, ScalarType t, bool big_endian, float* dst);

}  // namespace detail
}  // namespace isoloft
