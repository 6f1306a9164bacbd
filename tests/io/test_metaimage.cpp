#include <gtest/gtest.h>
#include <zlib.h>

#include <array>
#include <cmath>
#include <filesystem>

#include "io/io_test_util.h"
#include "isoloft/core/error.h"
#include "isoloft/io/metaimage.h"

using isoloft::InputError;
using isoloft::read_metaimage;
using isoloft::Volume;
using isoloft::test::TempDir;

namespace {
// The shared data folder sits beside the checkout (../shared/data, see its README).
const std::string kFrog = std::string(ISOLOFT_SOURCE_DIR) + "/../shared/data/frog/frogtissue.mhd";

std::vector<unsigned char> zlib_compress(const std::vector<unsigned char>& raw) {
  std::vector<unsigned char> z(compressBound(uLong(raw.size())));
  uLongf n = uLongf(z.size());
  EXPECT_EQ(compress(z.data(), &n, raw.data(), uLong(raw.size())), Z_OK);
  z.resize(n);
  return z;
}
}  // namespace

TEST(MetaImage, FrogLabelMap) {
  if (!std::filesystem::exists(kFrog)) GTEST_SKIP() << kFrog << " not present";
  const Volume v = read_metaimage(kFrog);
  ASSERT_EQ(v.nx, 500);
  ASSERT_EQ(v.ny, 470);
  ASSERT_EQ(v.nz, 136);
  EXPECT_EQ(v.spacing, (std::array<double, 3>{1.0, 1.0, 1.5}));
  EXPECT_EQ(v.origin, (std::array<double, 3>{0.0, 0.0, 0.0}));
  ASSERT_EQ(v.data.size(), std::size_t(500) * 470 * 136);
  std::array<std::size_t, 30> histogram{};
  for (std::size_t i = 0; i < v.data.size(); ++i) {
    const float l = v.data[i];
    ASSERT_TRUE(l >= 0.0f && l <= 29.0f && l == std::floor(l)) << "voxel " << i << " holds " << l;
    ++histogram[std::size_t(l)];
  }
  // The README's 15 named organs are all present; background dominates.
  for (int label = 1; label <= 15; ++label) EXPECT_GT(histogram[std::size_t(label)], 0u) << "label " << label;
  EXPECT_GT(histogram[0], v.data.size() / 2) << "background should be most of the volume";
  // Plane order: in this data set plane 0 is empty and the others are
  // labelled; a z flip or a wrong plane stride would move the empty plane.
  auto labelled = [&](int z) {
    for (int y = 0; y < v.ny; ++y)
      for (int x = 0; x < v.nx; ++x)
        if (v.at(x, y, z) != 0.0f) return true;
    return false;
  };
  EXPECT_FALSE(labelled(0));
  EXPECT_TRUE(labelled(1));
  EXPECT_TRUE(labelled(v.nz - 1));
}

TEST(MetaImage, RawTypesByteOrderAndHeaderSize) {
  TempDir dir;
  // MET_SHORT big-endian with a 3-byte preamble skipped by HeaderSize.
  std::vector<unsigned char> raw{0xAA, 0xBB, 0xCC};
  for (std::int16_t s : {std::int16_t(-5), std::int16_t(1000), std::int16_t(3), std::int16_t(-1)}) {
    raw.push_back(std::uint8_t(std::uint16_t(s) >> 8));
    raw.push_back(std::uint8_t(std::uint16_t(s) & 0xFF));
  }
  isoloft::test::write_bytes(dir.file("s.raw"), raw);
  isoloft::test::write_text(dir.file("s.mhd"),
                            "ObjectType = Image\nNDims = 3\nDimSize = 2 2 1\nElementType = MET_SHORT\n"
                            "BinaryDataByteOrderMSB = True\nHeaderSize = 3\nElementSpacing = 0.5 0.25 3\n"
                            "Offset = -10 20 1.5\nElementDataFile = s.raw\n");
  Volume v = read_metaimage(dir.file("s.mhd"));
  EXPECT_EQ(v.data, (std::vector<float>{-5, 1000, 3, -1}));
  EXPECT_EQ(v.spacing, (std::array<double, 3>{0.5, 0.25, 3}));
  EXPECT_EQ(v.origin, (std::array<double, 3>{-10, 20, 1.5}));

  // MET_USHORT little-endian, zlib compressed, in a subdirectory.
  std::vector<unsigned char> us;
  for (std::uint16_t u : {std::uint16_t(0), std::uint16_t(65535), std::uint16_t(258)}) {
    us.push_back(std::uint8_t(u & 0xFF));
    us.push_back(std::uint8_t(u >> 8));
  }
  std::filesystem::create_directory(dir.file("d"));
  isoloft::test::write_bytes(dir.file("d/u.zraw"), zlib_compress(us));
  isoloft::test::write_text(dir.file("d/u.mhd"),
                            "NDims = 2\nDimSize = 3 1\nElementType = MET_USHORT\nCompressedData = True\n"
                            "ElementDataFile = u.zraw\n");
  v = read_metaimage(dir.file("d/u.mhd"));
  EXPECT_EQ(v.nz, 1);
  EXPECT_EQ(v.data, (std::vector<float>{0, 65535, 258}));

  // MET_FLOAT data LOCAL, after the header in the same file.
  std::string local =
      "NDims = 3\nDimSize = 1 1 2\nElementType = MET_FLOAT\nTransformMatrix = 1 0 0 0 1 0 0 0 1\n"
      "ElementDataFile = LOCAL\n";
  for (float f : {1.5f, -2.25f}) local.append(reinterpret_cast<const char*>(&f), 4);  // test host is little-endian
  isoloft::test::write_text(dir.file("f.mha"), local);
  v = read_metaimage(dir.file("f.mha"));
  EXPECT_EQ(v.data, (std::vector<float>{1.5f, -2.25f}));

  // MET_UCHAR raw, HeaderSize = -1: data at the end of the file.
  isoloft::test::write_bytes(dir.file("c.raw"), {9, 9, 1, 2});
  isoloft::test::write_text(dir.file("c.mhd"),
                            "NDims = 3\nDimSize = 2 1 1\nElementType = MET_UCHAR\nHeaderSize = -1\n"
                            "ElementDataFile = c.raw\n");
  EXPECT_EQ(read_metaimage(dir.file("c.mhd")).data, (std::vector<float>{1, 2}));
}

// MetaIO's text form (BinaryData = False) reads as its binary twin, values
// checked against the ElementType; MET_INT labels beyond 2^24 stay exact.
TEST(MetaImage, AsciiDataAndExactLargeLabels) {
  TempDir dir;
  const std::string head = "NDims = 3\nDimSize = 3 2 1\nElementType = MET_SHORT\nBinaryData = False\n";
  isoloft::test::write_text(dir.file("a.mha"), head + "ElementDataFile = LOCAL\n-5 1000\n3\t-1 0 7\n");
  EXPECT_EQ(read_metaimage(dir.file("a.mha")).data, (std::vector<float>{-5, 1000, 3, -1, 0, 7}));
  isoloft::test::write_text(dir.file("t.txt"), "1 2 3 4 5 6");
  isoloft::test::write_text(dir.file("t.mhd"), head + "ElementDataFile = t.txt\n");
  EXPECT_EQ(read_metaimage(dir.file("t.mhd")).data, (std::vector<float>{1, 2, 3, 4, 5, 6}));
  auto expect_error = [&](const std::string& data, const std::string& words) {
    isoloft::test::write_text(dir.file("e.mha"), head + "ElementDataFile = LOCAL\n" + data);
    try {
      (void)read_metaimage(dir.file("e.mha"));
      ADD_FAILURE() << "accepted " << data;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  expect_error("1 2 3 4     5", "ASCII data end after 5 of 6 samples");
  expect_error("1 2 3 4 5 6 7", "ASCII data hold more than the 6 samples");
  expect_error("1 2 3 40000 5 6", "ASCII sample 3 '40000' is not a valid value");
  expect_error("1 2 x 4 5 6", "ASCII sample 2 'x'");

  std::string ints = "NDims = 3\nDimSize = 4 1 1\nElementType = MET_INT\nElementDataFile = LOCAL\n";
  for (std::int32_t x : {0, 16777216, 16777217, 16777216}) ints.append(reinterpret_cast<const char*>(&x), 4);
  isoloft::test::write_text(dir.file("i.mha"), ints);
  const Volume v = read_metaimage(dir.file("i.mha"));
  ASSERT_EQ(v.value_table, (std::vector<std::int64_t>{0, 16777216, 16777217}));
  EXPECT_EQ(v.data, (std::vector<float>{0, 1, 2, 1}));
  EXPECT_EQ(v.value(2), 16777217.0);
}

TEST(MetaImage, BadFilesThrowInputError) {
  TempDir dir;
  const std::string head = "NDims = 3\nDimSize = 4 4 4\n";
  isoloft::test::write_bytes(dir.file("short.raw"), std::vector<unsigned char>(63));
  isoloft::test::write_bytes(dir.file("bad.zraw"), {0x78, 0x9c, 1, 2, 3, 4, 5});
  std::vector<unsigned char> wrong(32, 7);
  isoloft::test::write_bytes(dir.file("small.zraw"), zlib_compress(wrong));
  const std::pair<const char*, std::string> cases[] = {
      {"short.mhd", head + "ElementType = MET_UCHAR\nElementDataFile = short.raw\n"},
      {"bad.mhd", head + "ElementType = MET_UCHAR\nCompressedData = True\nElementDataFile = bad.zraw\n"},
      {"small.mhd", head + "ElementType = MET_UCHAR\nCompressedData = True\nElementDataFile = small.zraw\n"},
      {"nofile.mhd", head + "ElementType = MET_UCHAR\nElementDataFile = nowhere.raw\n"},
      {"type.mhd", head + "ElementType = MET_LONG_LONG\nElementDataFile = short.raw\n"},
      {"dims.mhd", "NDims = 3\nDimSize = 4 4\nElementType = MET_UCHAR\nElementDataFile = short.raw\n"},
      {"rgb.mhd", head + "ElementType = MET_UCHAR\nElementNumberOfChannels = 3\nElementDataFile = short.raw\n"},
      {"shear.mhd", head + "TransformMatrix = 1 0 0 0.5 1 0 0 0 1\nElementType = MET_UCHAR\nElementDataFile = short.raw\n"},
      {"nodata.mhd", head + "ElementType = MET_UCHAR\n"},
      {"junk.mhd", "this is not a header\n"},
  };
  for (const auto& [name, text] : cases) isoloft::test::write_text(dir.file(name), text);
  for (const auto& [name, text] : cases) {
    try {
      (void)read_metaimage(dir.file(name));
      ADD_FAILURE() << "accepted " << name;
    } catch (const InputError& e) {
      // The error names the header, or the data file when the data is bad.
      EXPECT_NE(std::string(e.what()).find(dir.path().string()), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(read_metaimage(dir.file("missing.mhd")), InputError);
}
