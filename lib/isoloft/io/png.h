// PNG slice images via libpng (http://www.libpng.org/pub/png/libpng-manual.txt).
// Reading keeps the raw sample values (no gamma or colour-space conversion) so
// label values and 16-bit masks survive exactly; libpng errors are turned into
// InputError through png_set_error_fn + setjmp, so a corrupt file never aborts.
#pragma once

#include <cstdint>
#include <string>

#include "isoloft/core/grid.h"

namespace isoloft {

/// A decoded PNG. `values` holds per pixel:
///  - gray (1, 2, 4, 8, 16 bit): the gray level (1/2/4-bit scaled up to 8 bit,
///    so a 1-bit mask reads as 0/255);
///  - gray+alpha: the gray level, or 0 where alpha == 0;
///  - RGB / palette: 0xRRGGBB (16-bit channels rounded to 8 bit);
///  - RGBA / palette with transparency: like RGB, or 0 where alpha == 0.
struct RawImage {
  Grid2u32 values;
  std::uint32_t max_value = 255;  ///< 255 or 65535 for gray, 0xFFFFFF for colour
  int channels = 1;               ///< of the file: 1 gray, 2 gray+alpha, 3 RGB, 4 RGBA; palette: 3 (4 with tRNS)
  int bit_depth = 8;              ///< of the file (1, 2, 4, 8, 16)
  [[nodiscard]] bool color() const { return max_value == 0xFFFFFFu; }
};

/// Read an 8- or 16-bit PNG of any colour type (see RawImage).
/// \throw InputError(path, ...) if the file is missing, not a PNG, truncated or corrupt.
RawImage read_png(const std::string& path);

/// Write an 8-bit grayscale PNG (atomically, see atomic_file.h).
/// \pre image is non-empty.  \throw Error naming the path if writing fails.
void write_png(const std::string& path, const Grid2<std::uint8_t>& image);

/// Write a 16-bit grayscale PNG (atomically).
/// \pre image is non-empty.  \throw Error naming the path if writing fails.
void write_png16(const std::string& path, const Grid2<std::uint16_t>& image);

/// Write an 8-bit RGB PNG from packed 0xRRGGBB values (bits above 24 ignored; atomically).
/// \pre image is non-empty.  \throw Error naming the path if writing fails.
void write_png_rgb(const std::string& path, const Grid2u32& packed);

}  // namespace isoloft
