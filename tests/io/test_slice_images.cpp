#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include <algorithm>

#include "io/io_test_util.h"
#include "isoloft/core/error.h"
#include "isoloft/io/png.h"
#include "isoloft/io/slice_images.h"

using isoloft::InputError;
using isoloft::list_slice_files;
using isoloft::read_slice_images;
using isoloft::detail::natural_less;
using isoloft::test::TempDir;

TEST(NaturalOrder, DigitRunsCompareByValue) {
  EXPECT_TRUE(natural_less("slice2.png", "slice10.png"));
  EXPECT_FALSE(natural_less("slice10.png", "slice2.png"));
  EXPECT_TRUE(natural_less("a9b", "a10a"));
  EXPECT_TRUE(natural_less("img_1_3", "img_1_20"));
  EXPECT_TRUE(natural_less("x99999999999999999999998", "x99999999999999999999999"));  // beyond 64 bit
  EXPECT_TRUE(natural_less("s", "s1"));
  EXPECT_TRUE(natural_less("Slice2", "slice10"));  // case ignored outside ties
  EXPECT_TRUE(natural_less("A", "a"));             // tie: plain order
  EXPECT_FALSE(natural_less("s1", "s1"));
  // Equal value, different spelling: still a strict total order.
  EXPECT_NE(natural_less("a01", "a1"), natural_less("a1", "a01"));
}

RC_GTEST_PROP(NaturalOrderProperty, IsAStrictWeakOrderMatchingNumbers, (unsigned a, unsigned b)) {
  const std::string sa = "slice" + std::to_string(a) + ".png", sb = "slice" + std::to_string(b) + ".png";
  RC_ASSERT(natural_less(sa, sb) == (a < b));
  RC_ASSERT(!(natural_less(sa, sb) && natural_less(sb, sa)));
}

TEST(SliceFiles, DirectoryListsPngsInNaturalOrder) {
  TempDir dir;
  const isoloft::Grid2u8 img(2, 2, 0);
  for (const char* n : {"slice10.png", "slice2.png", "slice1.png", "SLICE3.PNG", "slice11.Png"})
    isoloft::write_png(dir.file(n), img);
  isoloft::test::write_text(dir.file("notes.txt"), "not a slice");
  isoloft::test::write_text(dir.file(".hidden.png"), "editor backup");
  std::filesystem::create_directory(dir.file("sub.png"));  // a directory is not a slice
  const auto files = list_slice_files({dir.path().string()});
  std::vector<std::string> names;
  for (const auto& f : files) names.push_back(std::filesystem::path(f).filename().string());
  const std::vector<std::string> expected{"slice1.png", "slice2.png", "SLICE3.PNG", "slice10.png", "slice11.Png"};
  EXPECT_EQ(names, expected);
  for (const auto& f : files) EXPECT_EQ(std::filesystem::path(f).parent_path(), dir.path()) << f;
}

TEST(SliceFiles, ExplicitFilesKeepTheirOrder) {
  TempDir dir;
  isoloft::write_png(dir.file("b.png"), isoloft::Grid2u8(2, 2));
  isoloft::write_png(dir.file("a.png"), isoloft::Grid2u8(2, 2));
  const std::vector<std::string> in{dir.file("b.png"), dir.file("a.png")};
  EXPECT_EQ(list_slice_files(in), in);
}

TEST(SliceFiles, Errors) {
  TempDir dir;
  EXPECT_THROW(list_slice_files({}), InputError);
  try {
    list_slice_files({dir.file("nope.png")});
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.file, dir.file("nope.png"));
  }
  std::filesystem::create_directory(dir.file("empty"));
  try {
    list_slice_files({dir.file("empty")});
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no .png"), std::string::npos) << e.what();
  }
  isoloft::write_png(dir.file("a.png"), isoloft::Grid2u8(2, 2));
  EXPECT_THROW(list_slice_files({dir.file("a.png"), dir.file("empty")}), InputError);
}

TEST(SliceImages, ReadsStack) {
  TempDir dir;
  std::vector<std::string> files;
  for (int k = 0; k < 5; ++k) {
    isoloft::Grid2u8 g(6, 4, 0);
    g(k, k % 4) = 255;
    files.push_back(dir.file("s" + std::to_string(k) + ".png"));
    isoloft::write_png(files.back(), g);
  }
  const isoloft::SliceStack st = read_slice_images(list_slice_files({dir.path().string()}));
  EXPECT_EQ(st.width, 6);
  EXPECT_EQ(st.height, 4);
  EXPECT_EQ(st.max_value, 255u);
  EXPECT_FALSE(st.has_polygons());
  EXPECT_EQ(st.pixel_size, 1.0);
  ASSERT_EQ(st.slices.size(), 5u);
  for (int k = 0; k < 5; ++k) {
    const auto& s = st.slices[std::size_t(k)];
    EXPECT_EQ(s.z, double(k)) << "slice " << k;
    EXPECT_EQ(s.source, files[std::size_t(k)]) << "slice " << k;
    EXPECT_TRUE(s.polygons.empty());
    for (int y = 0; y < 4; ++y)
      for (int x = 0; x < 6; ++x)
        ASSERT_EQ(s.image(x, y), (x == k && y == k % 4) ? 255u : 0u) << "slice " << k << " pixel " << x << "," << y;
  }
}

TEST(SliceImages, Gray16AndColourStacks) {
  TempDir dir;
  isoloft::write_png16(dir.file("a.png"), isoloft::Grid2<std::uint16_t>(3, 3, 40000));
  isoloft::write_png16(dir.file("b.png"), isoloft::Grid2<std::uint16_t>(3, 3, 7));
  auto st = read_slice_images({dir.file("a.png"), dir.file("b.png")});
  EXPECT_EQ(st.max_value, 65535u);
  EXPECT_EQ(st.slices[1].image(2, 2), 7u);
  isoloft::write_png_rgb(dir.file("c.png"), isoloft::Grid2u32(3, 3, 0x102030u));
  st = read_slice_images({dir.file("c.png")});
  EXPECT_EQ(st.max_value, 0xFFFFFFu);
  EXPECT_EQ(st.slices[0].image(0, 0), 0x102030u);
}

TEST(SliceImages, SizeMismatchNamesBothFiles) {
  TempDir dir;
  isoloft::write_png(dir.file("s1.png"), isoloft::Grid2u8(500, 470));
  isoloft::write_png(dir.file("s2.png"), isoloft::Grid2u8(480, 500));
  try {
    read_slice_images({dir.file("s1.png"), dir.file("s2.png")});
    FAIL() << "size mismatch accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), dir.file("s2.png") + ": 480x500, expected 500x470 like " + dir.file("s1.png"));
  }
}

TEST(SliceImages, MixedKindsAndCorruptSlicesAreRejected) {
  TempDir dir;
  isoloft::write_png(dir.file("g.png"), isoloft::Grid2u8(3, 3));
  isoloft::write_png_rgb(dir.file("c.png"), isoloft::Grid2u32(3, 3));
  isoloft::write_png16(dir.file("w.png"), isoloft::Grid2<std::uint16_t>(3, 3));
  isoloft::test::write_text(dir.file("bad.png"), "garbage");
  auto expect_error = [&](const std::vector<std::string>& files, const std::string& file, const std::string& part) {
    try {
      read_slice_images(files);
      ADD_FAILURE() << "accepted " << file;
    } catch (const InputError& e) {
      EXPECT_EQ(e.file, file);
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
    }
  };
  expect_error({dir.file("g.png"), dir.file("c.png")}, dir.file("c.png"), "colour image, expected grayscale");
  expect_error({dir.file("c.png"), dir.file("g.png")}, dir.file("g.png"), "grayscale image, expected colour");
  expect_error({dir.file("g.png"), dir.file("w.png")}, dir.file("w.png"), "16-bit grayscale, expected 8-bit");
  expect_error({dir.file("g.png"), dir.file("bad.png"), dir.file("c.png")}, dir.file("bad.png"), "not a PNG");
}
