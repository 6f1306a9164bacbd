#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>
#include <zlib.h>

#include <bit>
#include <cmath>
#include <filesystem>

#include "io/io_test_util.h"
#include "isoloft/core/error.h"
#include "isoloft/io/nrrd.h"

using isoloft::Grid2f;
using isoloft::InputError;
using isoloft::NrrdEncoding;
using isoloft::NrrdWriter;
using isoloft::read_nrrd;
using isoloft::Volume;
using isoloft::test::TempDir;

namespace {

Volume ramp(int nx, int ny, int nz) {
  Volume v;
  v.nx = nx, v.ny = ny, v.nz = nz;
  v.spacing = {0.8, 0.8, 2.5};
  v.origin = {-12.25, 3.0, 1e-3};
  v.data.resize(std::size_t(nx) * std::size_t(ny) * std::size_t(nz));
  for (std::size_t i = 0; i < v.data.size(); ++i) v.data[i] = std::sin(float(i) * 0.37f) * 100.0f - 3.0f;
  return v;
}

void expect_same_volume(const Volume& got, const Volume& want) {
  ASSERT_EQ(got.nx, want.nx);
  ASSERT_EQ(got.ny, want.ny);
  ASSERT_EQ(got.nz, want.nz);
  EXPECT_EQ(got.spacing, want.spacing);  // exact: header numbers are printed in round-trip form
  EXPECT_EQ(got.origin, want.origin);
  ASSERT_EQ(got.data.size(), want.data.size());
  for (int z = 0; z < want.nz; ++z)
    for (int y = 0; y < want.ny; ++y)
      for (int x = 0; x < want.nx; ++x)
        ASSERT_EQ(got.at(x, y, z), want.at(x, y, z)) << "voxel (" << x << ", " << y << ", " << z << ")";
}

}  // namespace

TEST(Nrrd, RoundTripRawAndGzip) {
  TempDir dir;
  const Volume v = ramp(7, 5, 4);
  for (const auto enc : {NrrdEncoding::Raw, NrrdEncoding::Gzip}) {
    const std::string path = dir.file(enc == NrrdEncoding::Raw ? "raw.nrrd" : "gz.nrrd");
    isoloft::write_nrrd(path, v, enc);
    SCOPED_TRACE(path);
    expect_same_volume(read_nrrd(path), v);
  }
  EXPECT_EQ(dir.entries().size(), 2u) << "temp files left behind";
}

TEST(Nrrd, HeaderIsStandard) {
  TempDir dir;
  const std::string path = dir.file("h.nrrd");
  isoloft::write_nrrd(path, ramp(3, 2, 2));
  const std::string text = isoloft::test::read_text(path);
  for (const char* line : {"NRRD0004\n", "\ntype: float\n", "\ndimension: 3\n", "\nspace dimension: 3\n",
                           "\nsizes: 3 2 2\n", "\nspace directions: (0.8,0,0) (0,0.8,0) (0,0,2.5)\n",
                           "\nendian: little\n", "\nencoding: raw\n", "\nspace origin: (-12.25,3,0.001)\n\n"})
    EXPECT_NE(text.find(line), std::string::npos) << "missing header line: " << line;
  // Raw data follows the blank line: exactly 3*2*2 floats.
  const std::size_t data_at = text.find("\n\n") + 2;
  EXPECT_EQ(text.size() - data_at, 12u * sizeof(float));
}

TEST(Nrrd, StreamingWriterChecksPlanes) {
  TempDir dir;
  const std::string path = dir.file("s.nrrd");
  {
    NrrdWriter w(path, 4, 3, 3, {1, 1, 1}, {0, 0, 0}, NrrdEncoding::Gzip);
    EXPECT_THROW(w.write_plane(Grid2f(3, 4)), isoloft::ParamError);
    w.write_plane(Grid2f(4, 3, 1.f));
    w.write_plane(Grid2f(4, 3, 2.f));
    EXPECT_EQ(w.planes_written(), 2);
    try {
      w.finish();
      FAIL() << "finish() accepted 2 of 3 planes";
    } catch (const isoloft::Error& e) {
      EXPECT_NE(std::string(e.what()).find("only 2 of 3"), std::string::npos) << e.what();
    }
  }
  EXPECT_TRUE(dir.entries().empty()) << "an unfinished volume must leave no file";

  NrrdWriter w(path, 2, 2, 1, {1, 1, 1}, {0, 0, 0});
  w.write_plane(Grid2f(2, 2, 5.f));
  EXPECT_THROW(w.write_plane(Grid2f(2, 2)), isoloft::ParamError);
  w.finish();
  EXPECT_EQ(read_nrrd(path).data, std::vector<float>(4, 5.f));
  EXPECT_THROW(NrrdWriter(dir.file("bad.nrrd"), 0, 2, 2, {1, 1, 1}, {0, 0, 0}), isoloft::ParamError);
  EXPECT_THROW(NrrdWriter(dir.file("bad.nrrd"), 2, 2, 2, {1, -1, 1}, {0, 0, 0}), isoloft::ParamError);
}

TEST(Nrrd, ReadsOtherTypesEndiansAndDetachedData) {
  TempDir dir;
  // uchar, raw, 2D
  std::string a = "NRRD0005\n# c\ntype: unsigned char\ndimension: 2\nsizes: 3 2\nspacings: 0.5 2\nencoding: raw\n\n";
  a += std::string("\x00\x01\x02\x03\x04\xff", 6);
  isoloft::test::write_text(dir.file("u8.nrrd"), a);
  const Volume u = read_nrrd(dir.file("u8.nrrd"));
  EXPECT_EQ(u.nz, 1);
  EXPECT_EQ(u.spacing[0], 0.5);
  EXPECT_EQ(u.spacing[1], 2.0);
  EXPECT_EQ(u.data, (std::vector<float>{0, 1, 2, 3, 4, 255}));

  // big-endian short in a detached, gzip-compressed data file
  std::string raw;
  for (std::int16_t s : {std::int16_t(-2), std::int16_t(300), std::int16_t(7), std::int16_t(-32768)}) {
    const auto u16 = std::uint16_t(s);
    raw.push_back(char(u16 >> 8));
    raw.push_back(char(u16 & 0xFF));
  }
  gzFile gz = gzopen(dir.file("s16.raw.gz").c_str(), "wb");  // a real gzip member, as "encoding: gzip" says
  ASSERT_NE(gz, nullptr);
  ASSERT_EQ(gzwrite(gz, raw.data(), unsigned(raw.size())), int(raw.size()));
  gzclose(gz);
  isoloft::test::write_text(dir.file("s16.nhdr"),
                            "NRRD0004\ntype: short\ndimension: 3\nspace dimension: 3\nsizes: 2 1 2\nendian: big\nencoding: gzip\n"
                            "space directions: (2,0,0) (0,3,0) (0,0,4)\nspace origin: (1,2,3)\n"
                            "data file: s16.raw.gz\n");
  const Volume s = read_nrrd(dir.file("s16.nhdr"));
  EXPECT_EQ(s.data, (std::vector<float>{-2, 300, 7, -32768}));
  EXPECT_EQ(s.spacing, (std::array<double, 3>{2, 3, 4}));
  EXPECT_EQ(s.origin, (std::array<double, 3>{1, 2, 3}));
}

TEST(Nrrd, CorruptFilesThrowInputError) {
  TempDir dir;
  isoloft::write_nrrd(dir.file("ok.nrrd"), ramp(8, 8, 8), NrrdEncoding::Gzip);
  const auto bytes = isoloft::test::read_bytes(dir.file("ok.nrrd"));
  isoloft::test::write_bytes(dir.file("cut.nrrd"), {bytes.begin(), bytes.end() - 100});
  auto flipped = bytes;
  flipped[bytes.size() - 300] ^= 0xFF;
  isoloft::test::write_bytes(dir.file("flip.nrrd"), flipped);
  isoloft::write_nrrd(dir.file("okraw.nrrd"), ramp(4, 4, 4));
  const auto raw = isoloft::test::read_bytes(dir.file("okraw.nrrd"));
  isoloft::test::write_bytes(dir.file("cutraw.nrrd"), {raw.begin(), raw.end() - 4});
  isoloft::test::write_text(dir.file("magic.nrrd"), "P5\n3 3\n");
  isoloft::test::write_text(dir.file("type.nrrd"), "NRRD0004\ntype: block\ndimension: 3\nsizes: 1 1 1\n\n");
  isoloft::test::write_text(dir.file("dim.nrrd"), "NRRD0004\ntype: float\ndimension: 4\nsizes: 1 1 1 1\n\n");
  isoloft::test::write_text(dir.file("enc.nrrd"),
                            "NRRD0004\ntype: float\ndimension: 3\nsizes: 1 1 1\nencoding: bzip2\n\n");
  isoloft::test::write_text(dir.file("rot.nrrd"),
                            "NRRD0004\ntype: float\ndimension: 3\nsizes: 1 1 1\n"
                            "space directions: (0,1,0) (1,0,0) (0,0,1)\n\n1234");
  // 1.6 GB declared, a few bytes of gzip: rejected before allocating.
  isoloft::test::write_text(dir.file("huge.nrrd"),
                            "NRRD0004\ntype: float\ndimension: 3\nsizes: 1000 1000 400\n"
                            "encoding: gzip\n\n\x1f\x8b\x08\x00\x00");
  for (const char* name : {"huge.nrrd", "missing.nrrd", "cut.nrrd", "flip.nrrd", "cutraw.nrrd", "magic.nrrd",
                           "type.nrrd", "dim.nrrd", "enc.nrrd", "rot.nrrd"}) {
    try {
      (void)read_nrrd(dir.file(name));
      ADD_FAILURE() << "accepted " << name;
    } catch (const InputError& e) {
      EXPECT_EQ(e.file, dir.file(name)) << e.what();
    }
  }
}

RC_GTEST_PROP(NrrdProperty, ArbitraryFloatsRoundTripBitExactly, ()) {
  Volume v;
  v.nx = *rc::gen::inRange(1, 9);
  v.ny = *rc::gen::inRange(1, 9);
  v.nz = *rc::gen::inRange(1, 5);
  v.spacing = {*rc::gen::inRange(1, 1000) * 0.01, *rc::gen::inRange(1, 1000) * 0.01, *rc::gen::inRange(1, 1000) * 0.1};
  v.origin = {*rc::gen::inRange(-500, 500) * 0.3, 0.0, *rc::gen::inRange(-500, 500) * 1.7};
  // Arbitrary bit patterns, including NaN payloads and infinities, must survive untouched.
  for (std::size_t i = 0; i < std::size_t(v.nx * v.ny * v.nz); ++i)
    v.data.push_back(std::bit_cast<float>(*rc::gen::arbitrary<std::uint32_t>()));
  const bool gzip = *rc::gen::arbitrary<bool>();
  TempDir dir;
  isoloft::write_nrrd(dir.file("p.nrrd"), v, gzip ? NrrdEncoding::Gzip : NrrdEncoding::Raw);
  const Volume r = read_nrrd(dir.file("p.nrrd"));
  RC_ASSERT(r.nx == v.nx && r.ny == v.ny && r.nz == v.nz);
  RC_ASSERT(r.spacing == v.spacing);
  RC_ASSERT(r.origin == v.origin);
  for (std::size_t i = 0; i < v.data.size(); ++i)
    RC_ASSERT(std::bit_cast<std::uint32_t>(r.data[i]) == std::bit_cast<std::uint32_t>(v.data[i]));
}

RC_GTEST_PROP(NrrdProperty, DamagedFilesThrowInputErrorOrRead, ()) {
  TempDir dir;
  const std::string path = dir.file("d.nrrd");
  const bool gzip = *rc::gen::arbitrary<bool>();
  isoloft::write_nrrd(path, ramp(5, 4, 3), gzip ? NrrdEncoding::Gzip : NrrdEncoding::Raw);
  auto bytes = isoloft::test::read_bytes(path);
  const int edits = *rc::gen::inRange(1, 4);
  for (int e = 0; e < edits; ++e)
    bytes[*rc::gen::inRange<std::size_t>(0, bytes.size())] = *rc::gen::arbitrary<unsigned char>();
  if (*rc::gen::arbitrary<bool>()) bytes.resize(*rc::gen::inRange<std::size_t>(0, bytes.size()));
  isoloft::test::write_bytes(path, bytes);
  try {
    const Volume v = read_nrrd(path);
    RC_ASSERT(v.data.size() == std::size_t(v.nx) * std::size_t(v.ny) * std::size_t(v.nz));
  } catch (const InputError& e) {
    RC_ASSERT(e.file.rfind(path, 0) == 0);
  }
}
