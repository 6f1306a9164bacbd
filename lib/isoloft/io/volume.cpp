#include "isoloft/io/volume.h"

#include <algorithm>
#include <bit>
#include <cstring>

#include "isoloft/core/error.h"

namespace isoloft {

Grid2f Volume::plane(int z) const {
  Grid2f g(nx, ny);
  const std::size_t n = std::size_t(nx) * std::size_t(ny);
  std::copy_n(data.begin() + std::ptrdiff_t(std::size_t(z) * n), n, g.data.begin());
  return g;
}

namespace detail {

std::size_t scalar_size(ScalarType t) {
  switch (t) {
    case ScalarType::U8:
    case ScalarType::I8:
      return 1;
    case ScalarType::U16:
    case ScalarType::I16:
      return 2;
    case ScalarType::U32:
    case ScalarType::I32:
    case ScalarType::F32:
      return 4;
    case ScalarType::F64:
      return 8;
  }
  return 1;
}

namespace {
template <class T>
void decode_as(const unsigned char* src, std::size_t count, bool swap, float* dst) {
  constexpr std::size_t S = sizeof(T);
  unsigned char b[S];
  for (std::size_t i = 0; i < count; ++i) {
    std::memcpy(b, src + i * S, S);
    if (swap) std::reverse(b, b + S);
    T v;
    std::memcpy(&v, b, S);
    dst[i] = static_cast<float>(v);
  }
}
}  // namespace

void decode_scalars(const unsigned char* src, std::size_t count, ScalarType t, bool big_endian, float* dst) {
  const bool swap = big_endian != (std::endian::native == std::endian::big);
  switch (t) {
    case ScalarType::U8:
      decode_as<std::uint8_t>(src, count, false, dst);
      break;
    case ScalarType::I8:
      decode_as<std::int8_t>(src, count, false, dst);
      break;
    case ScalarType::U16:
      decode_as<std::uint16_t>(src, count, swap, dst);
      break;
    case ScalarType::I16:
      decode_as<std::int16_t>(src, count, swap, dst);
      break;
    case ScalarType::U32:
      decode_as<std::uint32_t>(src, count, swap, dst);
      break;
    case ScalarType::I32:
      decode_as<std::int32_t>(src, count, swap, dst);
      break;
    case ScalarType::F32:
      decode_as<float>(src, count, swap, dst);
      break;
    case ScalarType::F64:
      decode_as<double>(src, count, swap, dst);
      break;
  }
}

}  // namespace detail
}  // namespace isoloft
