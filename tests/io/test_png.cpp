#include <gtest/gtest.h>
#include <png.h>
#include <rapidcheck/gtest.h>
#include <zlib.h>

#include <csetjmp>
#include <cstdio>
#include <filesystem>

#include "io/io_test_util.h"
#include "isoloft/core/error.h"
#include "isoloft/io/png.h"

using isoloft::Grid2;
using isoloft::Grid2u32;
using isoloft::InputError;
using isoloft::RawImage;
using isoloft::read_png;
using isoloft::test::TempDir;

namespace {

/// Writes a PNG of any colour type straight through libpng, independent of the
/// writers under test. `rows` are the packed PNG rows (big-endian samples).
struct PngSpec {
  int width = 0, height = 0, color_type = PNG_COLOR_TYPE_GRAY, bit_depth = 8;
  bool interlaced = false;
  std::vector<std::vector<png_byte>> rows;
  std::vector<png_color> palette;
  std::vector<png_byte> trns;  // palette alpha
};

PngSpec spec(int w, int h, int color_type, int bit_depth, bool interlaced = false) {
  PngSpec s;
  s.width = w, s.height = h, s.color_type = color_type, s.bit_depth = bit_depth, s.interlaced = interlaced;
  return s;
}

void write_spec(const std::string& path, const PngSpec& s) {
  std::vector<png_bytep> rows;
  for (const auto& r : s.rows) rows.push_back(const_cast<png_bytep>(r.data()));
  std::FILE* fp = std::fopen(path.c_str(), "wb");
  ASSERT_NE(fp, nullptr);
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  if (setjmp(png_jmpbuf(png))) FAIL() << "libpng error writing " << path;  // default handler longjmps here
  png_init_io(png, fp);
  png_set_IHDR(png, info, png_uint_32(s.width), png_uint_32(s.height), s.bit_depth, s.color_type,
               s.interlaced ? PNG_INTERLACE_ADAM7 : PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  if (!s.palette.empty()) png_set_PLTE(png, info, s.palette.data(), int(s.palette.size()));
  if (!s.trns.empty()) png_set_tRNS(png, info, s.trns.data(), int(s.trns.size()), nullptr);
  png_write_info(png, info);
  png_write_image(png, rows.data());
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  std::fclose(fp);
}

void push16(std::vector<png_byte>& row, unsigned v) {
  row.push_back(png_byte(v >> 8));
  row.push_back(png_byte(v & 0xFF));
}

void expect_values(const RawImage& img, const Grid2u32& expected) {
  ASSERT_EQ(img.values.width, expected.width);
  ASSERT_EQ(img.values.height, expected.height);
  for (int y = 0; y < expected.height; ++y)
    for (int x = 0; x < expected.width; ++x)
      ASSERT_EQ(img.values(x, y), expected(x, y)) << "pixel (" << x << ", " << y << ")";
}

}  // namespace

TEST(Png, Gray8RoundTrip) {
  TempDir dir;
  isoloft::Grid2u8 g(7, 5);
  for (std::size_t i = 0; i < g.data.size(); ++i) g.data[i] = std::uint8_t(i * 37);
  isoloft::write_png(dir.file("g8.png"), g);
  const RawImage img = read_png(dir.file("g8.png"));
  EXPECT_EQ(img.max_value, 255u);
  EXPECT_EQ(img.channels, 1);
  EXPECT_EQ(img.bit_depth, 8);
  EXPECT_FALSE(img.color());
  Grid2u32 expected(7, 5);
  for (std::size_t i = 0; i < g.data.size(); ++i) expected.data[i] = g.data[i];
  expect_values(img, expected);
}

TEST(Png, Gray16RoundTripBothWriters) {
  TempDir dir;
  Grid2<std::uint16_t> g(6, 4);
  for (std::size_t i = 0; i < g.data.size(); ++i) g.data[i] = std::uint16_t(i * 2749 + 1);
  isoloft::write_png16(dir.file("a.png"), g);
  PngSpec s = spec(6, 4, PNG_COLOR_TYPE_GRAY, 16);
  for (int y = 0; y < 4; ++y) {
    s.rows.emplace_back();
    for (int x = 0; x < 6; ++x) push16(s.rows.back(), g(x, y));
  }
  write_spec(dir.file("b.png"), s);
  Grid2u32 expected(6, 4);
  for (std::size_t i = 0; i < g.data.size(); ++i) expected.data[i] = g.data[i];
  for (const char* name : {"a.png", "b.png"}) {
    SCOPED_TRACE(name);
    const RawImage img = read_png(dir.file(name));
    EXPECT_EQ(img.max_value, 65535u);
    EXPECT_EQ(img.bit_depth, 16);
    expect_values(img, expected);
  }
}

TEST(Png, Gray1BitScalesTo255) {
  TempDir dir;
  PngSpec s = spec(10, 2, PNG_COLOR_TYPE_GRAY, 1);
  s.rows = {{0b10110000, 0b01000000}, {0b00000000, 0b11000000}};
  write_spec(dir.file("mask.png"), s);
  const RawImage img = read_png(dir.file("mask.png"));
  EXPECT_EQ(img.max_value, 255u);
  EXPECT_EQ(img.bit_depth, 1);
  Grid2u32 expected(10, 2, 0);
  for (int x : {0, 2, 3, 9}) expected(x, 0) = 255;
  for (int x : {8, 9}) expected(x, 1) = 255;
  expect_values(img, expected);
}

TEST(Png, GrayAlphaZeroWhereTransparent) {
  TempDir dir;
  PngSpec s8 = spec(3, 1, PNG_COLOR_TYPE_GRAY_ALPHA, 8);
  s8.rows = {{200, 255, 150, 0, 99, 1}};  // (gray, alpha) pairs
  write_spec(dir.file("ga8.png"), s8);
  RawImage img = read_png(dir.file("ga8.png"));
  EXPECT_EQ(img.channels, 2);
  EXPECT_EQ(img.max_value, 255u);
  Grid2u32 e8(3, 1);
  e8.data = {200, 0, 99};
  expect_values(img, e8);

  PngSpec s16 = spec(3, 1, PNG_COLOR_TYPE_GRAY_ALPHA, 16);
  s16.rows.emplace_back();
  for (unsigned v : {40000u, 65535u, 30000u, 0u, 12345u, 1u}) push16(s16.rows.back(), v);
  write_spec(dir.file("ga16.png"), s16);
  img = read_png(dir.file("ga16.png"));
  EXPECT_EQ(img.max_value, 65535u);
  Grid2u32 e(3, 1);
  e.data = {40000, 0, 12345};
  expect_values(img, e);
}

TEST(Png, RgbRoundTripAndRgb16Reduction) {
  TempDir dir;
  Grid2u32 packed(4, 3);
  for (std::size_t i = 0; i < packed.data.size(); ++i) packed.data[i] = std::uint32_t(i * 0x1F3A71u) & 0xFFFFFFu;
  isoloft::write_png_rgb(dir.file("rgb.png"), packed);
  RawImage img = read_png(dir.file("rgb.png"));
  EXPECT_EQ(img.max_value, 0xFFFFFFu);
  EXPECT_EQ(img.channels, 3);
  EXPECT_TRUE(img.color());
  expect_values(img, packed);

  // 16-bit channels c*257 are exactly representable in 8 bits as c.
  PngSpec s = spec(2, 1, PNG_COLOR_TYPE_RGB, 16);
  s.rows.emplace_back();
  for (unsigned c : {0x12u, 0xABu, 0xFFu, 0x00u, 0x80u, 0x7Fu}) push16(s.rows.back(), c * 257);
  write_spec(dir.file("rgb16.png"), s);
  img = read_png(dir.file("rgb16.png"));
  EXPECT_EQ(img.bit_depth, 16);
  Grid2u32 e(2, 1);
  e.data = {0x12ABFFu, 0x00807Fu};
  expect_values(img, e);
}

TEST(Png, RgbaZeroWhereTransparent) {
  TempDir dir;
  PngSpec s = spec(3, 1, PNG_COLOR_TYPE_RGB_ALPHA, 8);
  s.rows = {{1, 2, 3, 255, 4, 5, 6, 0, 7, 8, 9, 10}};
  write_spec(dir.file("rgba.png"), s);
  const RawImage img = read_png(dir.file("rgba.png"));
  EXPECT_EQ(img.channels, 4);
  Grid2u32 e(3, 1);
  e.data = {0x010203u, 0u, 0x070809u};
  expect_values(img, e);
}

TEST(Png, PaletteExpandsToRgb) {
  TempDir dir;
  PngSpec s = spec(4, 2, PNG_COLOR_TYPE_PALETTE, 8);
  s.palette = {{0, 0, 0}, {255, 0, 0}, {0, 128, 255}, {10, 20, 30}};
  s.rows = {{0, 1, 2, 3}, {3, 2, 1, 0}};
  write_spec(dir.file("pal.png"), s);
  RawImage img = read_png(dir.file("pal.png"));
  EXPECT_EQ(img.channels, 3);
  EXPECT_EQ(img.max_value, 0xFFFFFFu);
  Grid2u32 e(4, 2);
  e.data = {0x000000u, 0xFF0000u, 0x0080FFu, 0x0A141Eu, 0x0A141Eu, 0x0080FFu, 0xFF0000u, 0x000000u};
  expect_values(img, e);

  // 4-bit palette with a transparent entry 2.
  PngSpec t = spec(4, 1, PNG_COLOR_TYPE_PALETTE, 4);
  t.palette = s.palette;
  t.trns = {255, 255, 0, 255};
  t.rows = {{0x12, 0x31}};  // indices 1, 2, 3, 1
  write_spec(dir.file("pal4.png"), t);
  img = read_png(dir.file("pal4.png"));
  EXPECT_EQ(img.channels, 4);
  Grid2u32 e2(4, 1);
  e2.data = {0xFF0000u, 0u, 0x0A141Eu, 0xFF0000u};
  expect_values(img, e2);
}

TEST(Png, InterlacedReadsLikeProgressive) {
  TempDir dir;
  PngSpec s = spec(9, 9, PNG_COLOR_TYPE_GRAY, 8, true);
  Grid2u32 e(9, 9);
  for (int y = 0; y < 9; ++y) {
    s.rows.emplace_back();
    for (int x = 0; x < 9; ++x) {
      s.rows.back().push_back(png_byte(x * 9 + y));
      e(x, y) = std::uint32_t(x * 9 + y);
    }
  }
  write_spec(dir.file("adam7.png"), s);
  expect_values(read_png(dir.file("adam7.png")), e);
}

namespace {
void expect_input_error_naming(const std::string& path, const char* what_part) {
  try {
    (void)read_png(path);
    FAIL() << "no exception for " << path;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(what_part), std::string::npos) << e.what();
    EXPECT_EQ(e.file, path);
  }
}
}  // namespace

TEST(Png, BadFilesThrowInputErrorNamingThePath) {
  TempDir dir;
  expect_input_error_naming(dir.file("missing.png"), "cannot open");
  isoloft::test::write_text(dir.file("text.png"), "hello, not an image");
  expect_input_error_naming(dir.file("text.png"), "not a PNG");
  isoloft::test::write_text(dir.file("empty.png"), "");
  expect_input_error_naming(dir.file("empty.png"), "not a PNG");

  isoloft::Grid2u8 g(64, 64);
  for (std::size_t i = 0; i < g.data.size(); ++i) g.data[i] = std::uint8_t((i * 7919) >> 3);  // barely compressible
  isoloft::write_png(dir.file("good.png"), g);
  const auto bytes = isoloft::test::read_bytes(dir.file("good.png"));
  ASSERT_GT(bytes.size(), 200u);

  for (std::size_t cut : {std::size_t(12), std::size_t(40), bytes.size() / 2, bytes.size() - 13}) {
    SCOPED_TRACE("truncated at " + std::to_string(cut));
    const std::string p = dir.file("cut" + std::to_string(cut) + ".png");
    isoloft::test::write_bytes(p, std::vector<unsigned char>(bytes.begin(), bytes.begin() + std::ptrdiff_t(cut)));
    expect_input_error_naming(p, "corrupt PNG");
  }
  // Flip bytes inside the image data: CRC or inflate must fail, never crash.
  for (std::size_t at : {std::size_t(20), bytes.size() / 3, bytes.size() / 2}) {
    SCOPED_TRACE("corrupted at " + std::to_string(at));
    auto bad = bytes;
    bad[at] ^= 0x5A;
    const std::string p = dir.file("flip" + std::to_string(at) + ".png");
    isoloft::test::write_bytes(p, bad);
    expect_input_error_naming(p, "corrupt PNG");
  }
}

TEST(Png, HugeDeclaredSizeIsRejectedBeforeAllocating) {
  TempDir dir;
  isoloft::write_png(dir.file("one.png"), isoloft::Grid2u8(1, 1, 7));
  auto bytes = isoloft::test::read_bytes(dir.file("one.png"));
  // IHDR data starts at byte 16 (8 signature + 4 length + 4 type); claim 40000x40000
  // and fix the chunk CRC so libpng accepts the header itself.
  for (int k = 0; k < 2; ++k) {
    const std::uint32_t v = 40000;
    for (int b = 0; b < 4; ++b) bytes[std::size_t(16 + 4 * k + b)] = std::uint8_t(v >> (24 - 8 * b));
  }
  const uLong crc = crc32(0, bytes.data() + 12, 17);  // type + 13 data bytes
  for (int b = 0; b < 4; ++b) bytes[std::size_t(29 + b)] = std::uint8_t(crc >> (24 - 8 * b));
  isoloft::test::write_bytes(dir.file("huge.png"), bytes);
  expect_input_error_naming(dir.file("huge.png"), "cannot fit");
}

TEST(Png, WritersAreAtomicAndCreateDirectories) {
  TempDir dir;
  const std::string out = dir.file("deep/er/slice.png");
  isoloft::write_png(out, isoloft::Grid2u8(3, 3, 255));
  EXPECT_EQ(read_png(out).values(1, 1), 255u);
  EXPECT_THROW(isoloft::write_png(dir.file("empty.png"), isoloft::Grid2u8()), isoloft::Error);
  EXPECT_FALSE(std::filesystem::exists(dir.file("empty.png")));
  EXPECT_EQ(dir.entries().size(), 1u) << "temp file left behind";
}

RC_GTEST_PROP(PngProperty, Gray16AndRgbRoundTripExactly, ()) {
  const int w = *rc::gen::inRange(1, 40);
  const int h = *rc::gen::inRange(1, 40);
  Grid2<std::uint16_t> g(w, h);
  Grid2u32 rgb(w, h);
  for (auto& v : g.data) v = *rc::gen::arbitrary<std::uint16_t>();
  for (auto& v : rgb.data) v = *rc::gen::inRange<std::uint32_t>(0, 0x1000000u);
  TempDir dir;
  isoloft::write_png16(dir.file("g.png"), g);
  isoloft::write_png_rgb(dir.file("c.png"), rgb);
  const RawImage a = read_png(dir.file("g.png"));
  const RawImage b = read_png(dir.file("c.png"));
  for (std::size_t i = 0; i < g.data.size(); ++i) {
    RC_ASSERT(a.values.data[i] == std::uint32_t(g.data[i]));
    RC_ASSERT(b.values.data[i] == rgb.data[i]);
  }
}

RC_GTEST_PROP(PngProperty, DamagedFilesThrowInputErrorOrDecode, ()) {
  TempDir dir;
  isoloft::Grid2u8 g(16, 9);
  for (std::size_t i = 0; i < g.data.size(); ++i) g.data[i] = std::uint8_t(i * 13);
  const std::string path = dir.file("d.png");
  isoloft::write_png(path, g);
  auto bytes = isoloft::test::read_bytes(path);
  const int edits = *rc::gen::inRange(1, 4);
  for (int e = 0; e < edits; ++e)
    bytes[*rc::gen::inRange<std::size_t>(0, bytes.size())] = *rc::gen::arbitrary<unsigned char>();
  if (*rc::gen::arbitrary<bool>()) bytes.resize(*rc::gen::inRange<std::size_t>(0, bytes.size()));
  isoloft::test::write_bytes(path, bytes);
  try {
    const RawImage img = read_png(path);
    RC_ASSERT(img.values.data.size() == std::size_t(img.values.width) * std::size_t(img.values.height));
  } catch (const InputError& e) {
    RC_ASSERT(e.file == path);
  }
}
