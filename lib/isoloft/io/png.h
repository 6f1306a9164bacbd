// @file io/png.h
// @brief PNG slice images via libpng, raw sample values.
// No gamma or colour conversion (labels and 16-bit masks survive exactly);
// libpng errors become InputError, never an abort.
#pragma once

#include <cstdint>
#include <string>

#include "isoloft/core/grid.h"

namespace isoloft {

/// Per pixel the gray level (1/2/4 bit scaled to 8: a 1-bit mask is 0/255) or
/// 0xRRGGBB (16-bit channels rounded), 0 where alpha == 0.
struct RawImage {
  Grid2u32 values;
  std::uint32_t max_value = 255;  ///< 255 or 65535 for gray, 0xFFFFFF for colour
  int channels = 1;               ///< of the file: 1 gray, 2 gray+alpha, 3 RGB, 4 RGBA; palette: 3 (4 with tRNS)
  int bit_depth = 8;              ///< of the file (1, 2, 4, 8, 16)
  [[nodiscard]] bool color() const { return max_value == 0xFFFFFFu; }
};

/// \throw InputError(path, ...) if the file is missing, not a PNG or corrupt.
RawImage read_png(const std::string& path);

/// What read_png() would give, from the header alone (the pixels unread).
struct PngInfo {
  int width = 0, height = 0;
  std::uint32_t max_value = 255;  ///< as RawImage::max_value
  [[nodiscard]] bool color() const { return max_value == 0xFFFFFFu; }
};

/// \throw InputError(path, ...) if the file is missing, not a PNG or its header corrupt.
PngInfo read_png_info(const std::string& path);

/// Writers (8-bit gray, 16-bit gray, 8-bit RGB from 0xRRGGBB), atomic.
/// \throw Error naming the path if the image is empty or writing fails.
void write_png(const std::string& path, const Grid2<std::uint8_t>& image);

void write_png16(const std::string& path, const Grid2<std::uint16_t>& image);

void write_png_rgb(const std::string& path, const Grid2u32& packed);

}  // namespace isoloft
