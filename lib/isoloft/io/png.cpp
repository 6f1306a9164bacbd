#include "isoloft/io/png.h"

#include <png.h>
#include <unistd.h>

#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <vector>

#include "isoloft/core/error.h"
#include "isoloft/io/atomic_file.h"
#include "isoloft/io/file_util.h"

namespace isoloft {
namespace {

// libpng reports errors by calling the error function, which must not return.
// We store the message and longjmp back to the setjmp in decode()/encode().
// Those functions keep no locals with destructors (everything lives in the
// context), so the jump skips no C++ cleanup.
struct PngCtx {
  std::FILE* fp = nullptr;
  png_structp png = nullptr;
  png_infop info = nullptr;
  bool writing = false;
  bool header_only = false;  // stop after the header checks (read_png_info)
  char message[256] = {0};
  std::vector<png_byte> pixels;
  std::vector<png_bytep> rows;
  // header as read
  png_uint_32 width = 0, height = 0;
  int bit_depth = 0, color_type = 0;
  bool has_trns = false;
  long long file_size = 0;
  // after transforms
  int out_channels = 0, out_depth = 0;

  ~PngCtx() {
    if (png) {
      if (writing)
        png_destroy_write_struct(&png, &info);
      else
        png_destroy_read_struct(&png, &info, nullptr);
    }
    if (fp) std::fclose(fp);
  }
};

void on_png_error(png_structp png, png_const_charp msg) {
  auto* ctx = static_cast<PngCtx*>(png_get_error_ptr(png));
  std::snprintf(ctx->message, sizeof ctx->message, "%s", msg ? msg : "libpng error");
  png_longjmp(png, 1);
}
void on_png_warning(png_structp, png_const_charp) {}  // e.g. "iCCP: known incorrect sRGB profile": harmless

constexpr std::uint64_t max_pixels = std::uint64_t(1) << 31;  // Grid2 indexes with int sizes

bool decode(PngCtx& c) {
  if (setjmp(png_jmpbuf(c.png))) return false;
  png_init_io(c.png, c.fp);
  png_set_sig_bytes(c.png, 8);
  png_read_info(c.png, c.info);
  int interlace = 0;
  png_get_IHDR(c.png, c.info, &c.width, &c.height, &c.bit_depth, &c.color_type, &interlace, nullptr, nullptr);
  if (std::uint64_t(c.width) * c.height > max_pixels) {
    std::snprintf(c.message, sizeof c.message, "image too large (%ux%u)", unsigned(c.width), unsigned(c.height));
    return false;
  }
  c.has_trns = png_get_valid(c.png, c.info, PNG_INFO_tRNS) != 0;
  if (c.color_type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(c.png);
  if (c.color_type == PNG_COLOR_TYPE_GRAY && c.bit_depth < 8) png_set_expand_gray_1_2_4_to_8(c.png);
  if (c.has_trns) png_set_tRNS_to_alpha(c.png);
  if ((c.color_type & PNG_COLOR_MASK_COLOR) && c.bit_depth == 16) png_set_scale_16(c.png);  // rounds, not truncates
  png_set_interlace_handling(c.png);
  png_read_update_info(c.png, c.info);
  c.out_channels = png_get_channels(c.png, c.info);
  c.out_depth = png_get_bit_depth(c.png, c.info);
  const std::size_t rowbytes = png_get_rowbytes(c.png, c.info);
  // Deflate cannot compress better than 1032:1 and our transforms expand at
  // most 32x (1-bit palette -> RGBA): a larger image is a corrupt header,
  // caught here before allocating for it (factor 64 leaves slack).
  if (double(rowbytes) * c.height > 64.0 * 1032.0 * double(c.file_size) + 65536.0) {
    std::snprintf(c.message, sizeof c.message, "%ux%u image cannot fit in a %llu-byte file", unsigned(c.width),
                  unsigned(c.height), static_cast<unsigned long long>(c.file_size));
    return false;
  }
  if (c.header_only) return true;
  c.pixels.resize(rowbytes * c.height);
  c.rows.resize(c.height);
  for (png_uint_32 y = 0; y < c.height; ++y) c.rows[y] = c.pixels.data() + rowbytes * y;
  png_read_image(c.png, c.rows.data());
  png_read_end(c.png, nullptr);
  return true;
}

bool encode(PngCtx& c, int color_type) {
  if (setjmp(png_jmpbuf(c.png))) return false;
  png_init_io(c.png, c.fp);
  png_set_IHDR(c.png, c.info, c.width, c.height, c.bit_depth, color_type, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(c.png, c.info);
  png_write_image(c.png, c.rows.data());
  png_write_end(c.png, nullptr);
  return true;
}

// Shared writer: `c.pixels` holds big-endian rows, `c.width/height/bit_depth` set.
void write_rows(const std::string& path, PngCtx& c, int color_type, std::size_t rowbytes) {
  if (c.width == 0 || c.height == 0) throw Error(path + ": cannot write an empty image");
  c.rows.resize(c.height);
  for (png_uint_32 y = 0; y < c.height; ++y) c.rows[y] = c.pixels.data() + rowbytes * y;
  AtomicFile out(path);
  c.fp = std::fopen(out.temp_path().c_str(), "wb");
  if (!c.fp) throw Error(path + ": cannot create file (" + std::strerror(errno) + ")");
  c.writing = true;
  c.png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &c, on_png_error, on_png_warning);
  if (!c.png) throw Error(path + ": libpng initialisation failed");
  c.info = png_create_info_struct(c.png);
  if (!c.info) throw Error(path + ": libpng initialisation failed");
  if (!encode(c, color_type)) throw Error(path + ": cannot write PNG (" + c.message + ")");
  const bool io_error = std::ferror(c.fp) != 0;
  const bool close_error = std::fclose(c.fp) != 0;
  c.fp = nullptr;
  if (io_error || close_error) throw Error(path + ": write error (" + std::strerror(errno) + ")");
  out.commit();
}

// Opens and decodes `path` into c (its header only if c.header_only).
void read_into(const std::string& path, PngCtx& c) {
  const int fd = detail::open_regular_file(path);  // a FIFO or device refused, never waited on
  c.fp = ::fdopen(fd, "rb");
  if (!c.fp) {
    ::close(fd);
    throw InputError(path, std::string("cannot open file (") + std::strerror(errno) + ")");
  }
  if (std::fseek(c.fp, 0, SEEK_END) == 0) c.file_size = std::ftell(c.fp);
  std::rewind(c.fp);
  png_byte sig[8];
  if (std::fread(sig, 1, 8, c.fp) != 8 || png_sig_cmp(sig, 0, 8) != 0) throw InputError(path, "not a PNG file");
  c.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &c, on_png_error, on_png_warning);
  if (!c.png) throw InputError(path, "libpng initialisation failed");
  c.info = png_create_info_struct(c.png);
  if (!c.info) throw InputError(path, "libpng initialisation failed");
  if (!decode(c)) throw InputError(path, std::string("corrupt PNG (") + c.message + ")");
}

std::uint32_t max_value_of(const PngCtx& c) {
  const bool color = (c.color_type & PNG_COLOR_MASK_COLOR) != 0;
  return color ? 0xFFFFFFu : (c.out_depth == 16 ? 65535u : 255u);
}

}  // namespace

PngInfo read_png_info(const std::string& path) {
  PngCtx c;
  c.header_only = true;
  read_into(path, c);
  return {int(c.width), int(c.height), max_value_of(c)};
}

RawImage read_png(const std::string& path) {
  PngCtx c;
  read_into(path, c);
  RawImage img;
  img.bit_depth = c.bit_depth;
  switch (c.color_type) {
    case PNG_COLOR_TYPE_GRAY:
      img.channels = 1;
      break;
    case PNG_COLOR_TYPE_GRAY_ALPHA:
      img.channels = 2;
      break;
    case PNG_COLOR_TYPE_RGB:
      img.channels = 3;
      break;
    case PNG_COLOR_TYPE_RGB_ALPHA:
      img.channels = 4;
      break;
    case PNG_COLOR_TYPE_PALETTE:
      img.channels = c.has_trns ? 4 : 3;
      break;
    default:
      img.channels = c.out_channels;
  }
  img.max_value = max_value_of(c);
  const int w = int(c.width), h = int(c.height);
  img.values = Grid2u32(w, h);
  const int ch = c.out_channels;
  const bool wide = c.out_depth == 16;
  const std::size_t bps = wide ? 2 : 1;  // bytes per sample
  for (int y = 0; y < h; ++y) {
    const png_byte* row = c.rows[std::size_t(y)];
    std::uint32_t* dst = img.values.data.data() + img.values.index(0, y);
    for (int x = 0; x < w; ++x) {
      const png_byte* p = row + std::size_t(x) * std::size_t(ch) * bps;
      auto sample = [&](int i) -> std::uint32_t {
        return wide ? (std::uint32_t(p[2 * i]) << 8) | p[2 * i + 1] : std::uint32_t(p[i]);
      };
      std::uint32_t v = 0;
      if (ch <= 2) {
        v = sample(0);
        if (ch == 2 && sample(1) == 0) v = 0;
      } else {  // colour is always 8 bit after png_set_scale_16
        v = (std::uint32_t(p[0]) << 16) | (std::uint32_t(p[1]) << 8) | p[2];
        if (ch == 4 && p[3] == 0) v = 0;
      }
      dst[x] = v;
    }
  }
  return img;
}

void write_png(const std::string& path, const Grid2<std::uint8_t>& image) {
  PngCtx c;
  c.width = png_uint_32(image.width);
  c.height = png_uint_32(image.height);
  c.bit_depth = 8;
  c.pixels.assign(image.data.begin(), image.data.end());
  write_rows(path, c, PNG_COLOR_TYPE_GRAY, std::size_t(image.width));
}

void write_png16(const std::string& path, const Grid2<std::uint16_t>& image) {
  PngCtx c;
  c.width = png_uint_32(image.width);
  c.height = png_uint_32(image.height);
  c.bit_depth = 16;
  c.pixels.resize(image.data.size() * 2);
  for (std::size_t i = 0; i < image.data.size(); ++i) {  // PNG samples are big-endian
    c.pixels[2 * i] = png_byte(image.data[i] >> 8);
    c.pixels[2 * i + 1] = png_byte(image.data[i] & 0xFF);
  }
  write_rows(path, c, PNG_COLOR_TYPE_GRAY, std::size_t(image.width) * 2);
}

void write_png_rgb(const std::string& path, const Grid2u32& packed) {
  PngCtx c;
  c.width = png_uint_32(packed.width);
  c.height = png_uint_32(packed.height);
  c.bit_depth = 8;
  c.pixels.resize(packed.data.size() * 3);
  for (std::size_t i = 0; i < packed.data.size(); ++i) {
    const std::uint32_t v = packed.data[i];
    c.pixels[3 * i] = png_byte((v >> 16) & 0xFF);
    c.pixels[3 * i + 1] = png_byte((v >> 8) & 0xFF);
    c.pixels[3 * i + 2] = png_byte(v & 0xFF);
  }
  write_rows(path, c, PNG_COLOR_TYPE_RGB, std::size_t(packed.width) * 3);
}

}  // namespace isoloft
