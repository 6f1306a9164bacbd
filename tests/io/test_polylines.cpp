#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include "io/io_test_util.h"
#include "isoloft/core/error.h"
#include "isoloft/io/polylines.h"

using isoloft::InputError;
using isoloft::Polygon;
using isoloft::read_polylines;
using isoloft::SliceStack;
using isoloft::Vec2d;
using isoloft::write_polylines;
using isoloft::test::TempDir;

namespace {

void expect_same_stack(const SliceStack& got, const SliceStack& want) {
  EXPECT_TRUE(got.has_polygons());
  EXPECT_EQ(got.width, want.width);
  EXPECT_EQ(got.height, want.height);
  EXPECT_EQ(got.pixel_size, want.pixel_size);
  ASSERT_EQ(got.slices.size(), want.slices.size());
  for (std::size_t k = 0; k < want.slices.size(); ++k) {
    EXPECT_EQ(got.slices[k].z, want.slices[k].z) << "slice " << k;
    EXPECT_TRUE(got.slices[k].image.empty()) << "slice " << k;
    ASSERT_EQ(got.slices[k].polygons.size(), want.slices[k].polygons.size()) << "slice " << k;
    for (std::size_t c = 0; c < want.slices[k].polygons.size(); ++c) {
      const auto& g = got.slices[k].polygons[c].points;
      const auto& w = want.slices[k].polygons[c].points;
      ASSERT_EQ(g.size(), w.size()) << "slice " << k << " contour " << c;
      for (std::size_t i = 0; i < w.size(); ++i)  // exact: shortest round-trip number text
        ASSERT_EQ(g[i], w[i]) << "slice " << k << " contour " << c << " point " << i;
    }
  }
}

/// Expect read_polylines to fail with what() == "<path>:<line>: <problem...>".
void expect_error(const std::string& path, const std::string& text, int line, const std::string& problem) {
  isoloft::test::write_text(path, text);
  try {
    (void)read_polylines(path);
    ADD_FAILURE() << "accepted:\n" << text;
  } catch (const InputError& e) {
    const std::string prefix = line > 0 ? path + ":" + std::to_string(line) + ": " : path + ": ";
    EXPECT_EQ(std::string(e.what()).rfind(prefix + problem, 0), 0u)
        << "got: " << e.what() << "\nwant: " << prefix + problem;
  }
}

}  // namespace

TEST(Polylines, ReadsTheDocumentedFormat) {
  TempDir dir;
  const std::string path = dir.file("p.txt");
  isoloft::test::write_text(path,
                            "# comments start with '#'\n"
                            "\n"
                            "isoloft-polylines 1   # magic\n"
                            "size 500 470\n"
                            "pixel_size 0.8\n"
                            "slice 0\n"
                            "contour\n"
                            "12.5 40\n"
                            "100 40\r\n"  // CRLF tolerated
                            "100 200\n"
                            "12.5 40\n"  // explicit closing point is dropped
                            "contour\n"
                            "\t30 50\n"
                            "+60 50\n"
                            "60 1e2\n"
                            "slice 2.5\n"  // an empty slice
                            "slice 8\n"
                            "contour\n"
                            "-0.5 -0.5\n"
                            "499.5 -0.5\n"
                            "499.5 469.5\n");
  const SliceStack s = read_polylines(path);
  EXPECT_TRUE(s.has_polygons());
  EXPECT_EQ(s.width, 500);
  EXPECT_EQ(s.height, 470);
  EXPECT_EQ(s.pixel_size, 0.8);
  ASSERT_EQ(s.slices.size(), 3u);
  EXPECT_EQ(s.slices[0].z, 0.0);
  EXPECT_EQ(s.slices[1].z, 2.5);
  EXPECT_EQ(s.slices[2].z, 8.0);
  EXPECT_EQ(s.slices[0].source, path);
  ASSERT_EQ(s.slices[0].polygons.size(), 2u);
  EXPECT_EQ(s.slices[0].polygons[0].points, (std::vector<Vec2d>{{12.5, 40}, {100, 40}, {100, 200}}));
  EXPECT_EQ(s.slices[0].polygons[1].points, (std::vector<Vec2d>{{30, 50}, {60, 50}, {60, 100}}));
  EXPECT_TRUE(s.slices[1].polygons.empty());
  EXPECT_EQ(s.slices[2].polygons[0].points.size(), 3u);
}

TEST(Polylines, PixelSizeDefaultsToOne) {
  TempDir dir;
  isoloft::test::write_text(dir.file("p.txt"), "isoloft-polylines 1\nsize 4 4\nslice 0\n");
  EXPECT_EQ(read_polylines(dir.file("p.txt")).pixel_size, 1.0);
}

TEST(Polylines, RoundTrip) {
  TempDir dir;
  SliceStack s;
  s.kind = isoloft::InputKind::Polylines;
  s.width = 64;
  s.height = 48;
  s.pixel_size = 0.1 + 0.2;  // not a short decimal
  s.slices.resize(3);
  s.slices[0].z = -1.0 / 3.0;
  s.slices[0].polygons = {Polygon{{{1.0 / 7.0, 2}, {40.25, 3}, {20, 30.000000000000004}}}};
  s.slices[1].z = 2;  // empty slice
  s.slices[2].z = 2.000000000000001;
  s.slices[2].polygons = {Polygon{{{0, 0}, {63.5, 0}, {63.5, 47.5}, {0, 47.5}}},
                          Polygon{{{10, 10}, {20, 10}, {15, 20}}}};
  write_polylines(dir.file("a/out.txt"), s);
  expect_same_stack(read_polylines(dir.file("a/out.txt")), s);
}

TEST(Polylines, EachErrorNamesFileAndLine) {
  TempDir dir;
  const std::string p = dir.file("e.txt");
  const std::string head = "isoloft-polylines 1\nsize 10 10\n";
  expect_error(p, "", 0, "empty file");
  expect_error(p, "# only a comment\nsize 10 10\n", 2, "not an isoloft polyline file");
  expect_error(p, "isoloft-polylines 2\n", 1, "unsupported polyline format version");
  expect_error(p, "isoloft-polylines 1\nslice 0\n", 2, "missing 'size");
  expect_error(p, "isoloft-polylines 1\npixel_size 2\n", 0, "missing 'size");
  expect_error(p, "isoloft-polylines 1\nsize 10\n", 2, "expected 'size <width> <height>'");
  expect_error(p, "isoloft-polylines 1\nsize 10 -3\n", 2, "expected 'size <width> <height>'");
  expect_error(p, "isoloft-polylines 1\nsize 10 2.5\n", 2, "expected 'size <width> <height>'");
  expect_error(p, head + "size 10 10\n", 3, "duplicate 'size'");
  expect_error(p, head + "pixel_size 0\n", 3, "expected 'pixel_size");
  expect_error(p, head + "slice 0\npixel_size 2\n", 4, "'pixel_size' must come before the first slice");
  expect_error(p, head, 0, "no slices");
  expect_error(p, head + "slice\n", 3, "expected 'slice <z>'");
  expect_error(p, head + "slice nan\n", 3, "expected 'slice <z>'");
  expect_error(p, head + "slice 0\nslice 5\nslice 4\n", 5, "slice z 4 is not greater than the previous 5");
  expect_error(p, head + "slice 1\nslice 1\n", 4, "slice z 1 is not greater");
  expect_error(p, head + "contour\n", 3, "'contour' before any 'slice'");
  expect_error(p, head + "slice 0\n1 2\n", 4, "point outside a 'contour'");
  expect_error(p, head + "slice 0\ncontour\n1 2\n3\n", 6, "expected two numbers");
  expect_error(p, head + "slice 0\ncontour\n1 2 3\n", 5, "expected two numbers");
  expect_error(p, head + "slice 0\ncontour\n1 two\n", 5, "expected two numbers");
  expect_error(p, head + "slice 0\ncontour\n1 inf\n", 5, "point (1, inf) is not finite");
  expect_error(p, head + "slice 0\ncontour\n1 1\n2 2\nslice 1\n", 4, "contour with 2 distinct points");
  expect_error(p, head + "slice 0\ncontour\n1 1\n2 2\n1 1\n", 4, "contour with 2 distinct points");
  expect_error(p, head + "slice 0\ncontour\n1 1\n2 2\n3 1\ncontour\n", 8, "contour with 0 distinct points");
  expect_error(p, head + "slice 0\ncontour\n1 1\n10 2\n3 1\n", 6, "point (10, 2) outside the 10x10 grid");
  expect_error(p, head + "slice 0\ncontour\n-0.6 1\n", 5, "point (-0.6, 1) outside the 10x10 grid");
  expect_error(p, head + "slice 0\npolygon\n", 4, "unknown keyword 'polygon'");
  expect_error(p, head + "slice 0\ncontour 3\n", 4, "'contour' takes no arguments");
  try {
    (void)read_polylines(dir.file("missing.txt"));
    ADD_FAILURE() << "missing file accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file, dir.file("missing.txt"));
  }
}

TEST(Polylines, WriterRejectsWhatTheReaderWould) {
  TempDir dir;
  SliceStack s;
  s.kind = isoloft::InputKind::Polylines;
  s.width = s.height = 8;
  s.slices.resize(2);
  s.slices[0].z = 1;
  s.slices[1].z = 1;
  EXPECT_THROW(write_polylines(dir.file("a.txt"), s), isoloft::ParamError);
  s.slices[1].z = 2;
  s.slices[1].polygons = {Polygon{{{0, 0}, {1, 1}}}};
  EXPECT_THROW(write_polylines(dir.file("a.txt"), s), isoloft::ParamError);
  s.slices[1].polygons = {Polygon{{{0, 0}, {9, 1}, {1, 2}}}};
  EXPECT_THROW(write_polylines(dir.file("a.txt"), s), isoloft::ParamError);
  s.slices[1].polygons.clear();
  s.kind = isoloft::InputKind::Contours;
  EXPECT_THROW(write_polylines(dir.file("a.txt"), s), isoloft::ParamError);
  EXPECT_TRUE(dir.entries().empty());
}

RC_GTEST_PROP(PolylinesProperty, RandomStacksRoundTripExactly, ()) {
  SliceStack s;
  s.kind = isoloft::InputKind::Polylines;
  s.width = *rc::gen::inRange(1, 2000);
  s.height = *rc::gen::inRange(1, 2000);
  s.pixel_size = *rc::gen::inRange(1, 100000) * 1e-3;
  const int ns = *rc::gen::inRange(1, 6);
  double z = *rc::gen::inRange(-1000, 1000) * 0.37;
  for (int k = 0; k < ns; ++k) {
    isoloft::Slice sl;
    sl.z = z;
    z += *rc::gen::inRange(1, 10000) * 1e-3;  // strictly increasing, non-uniform
    const int nc = *rc::gen::inRange(0, 4);
    for (int c = 0; c < nc; ++c) {
      Polygon poly;
      const int np = *rc::gen::inRange(3, 12);
      for (int i = 0; i < np; ++i) {
        // Arbitrary doubles inside the pixel area [-0.5, size-0.5].
        const double u = *rc::gen::inRange(0, 1 << 30) / double(1 << 30);
        const double v = *rc::gen::inRange(0, 1 << 30) / double(1 << 30);
        poly.points.emplace_back(-0.5 + u * s.width, -0.5 + v * s.height);
      }
      if (poly.points.back() == poly.points.front()) poly.points.back().x() = poly.points.front().x() == 0 ? 0.25 : 0;
      sl.polygons.push_back(poly);
    }
    s.slices.push_back(sl);
  }
  TempDir dir;
  write_polylines(dir.file("r.txt"), s);
  const SliceStack r = read_polylines(dir.file("r.txt"));
  RC_ASSERT(r.width == s.width && r.height == s.height && r.pixel_size == s.pixel_size);
  RC_ASSERT(r.slices.size() == s.slices.size());
  for (std::size_t k = 0; k < s.slices.size(); ++k) {
    RC_ASSERT(r.slices[k].z == s.slices[k].z);
    RC_ASSERT(r.slices[k].polygons.size() == s.slices[k].polygons.size());
    for (std::size_t c = 0; c < s.slices[k].polygons.size(); ++c)
      RC_ASSERT(r.slices[k].polygons[c].points == s.slices[k].polygons[c].points);
  }
}

RC_GTEST_PROP(PolylinesProperty, DamagedFilesThrowInputErrorOrRead, ()) {
  TempDir dir;
  const std::string path = dir.file("d.txt");
  isoloft::test::write_text(path,
                            "isoloft-polylines 1\nsize 20 20\npixel_size 0.5\nslice 0\ncontour\n1 1\n10 1\n10 10\n"
                            "slice 3\ncontour\n2 2\n12 2.5\n8 15\ncontour\n3 3\n4 3\n4 4\n");
  auto bytes = isoloft::test::read_bytes(path);
  const int edits = *rc::gen::inRange(1, 4);
  for (int e = 0; e < edits; ++e)
    bytes[*rc::gen::inRange<std::size_t>(0, bytes.size())] =
        *rc::gen::element<unsigned char>('0', '9', '-', '.', ' ', '\n', 'e', 'x', 0);
  isoloft::test::write_bytes(path, bytes);
  try {
    const SliceStack s = read_polylines(path);
    for (std::size_t k = 0; k < s.slices.size(); ++k) {
      if (k > 0) RC_ASSERT(s.slices[k].z > s.slices[k - 1].z);
      for (const auto& poly : s.slices[k].polygons) RC_ASSERT(poly.points.size() >= 3u);
    }
  } catch (const InputError& e) {
    RC_ASSERT(e.file.rfind(path, 0) == 0);  // "path" or "path:line"
  }
}

// CR-only (old Mac) and CRLF line ends and a UTF-8 byte-order mark read the
// same as plain LF; line numbers in errors count those line ends too.
TEST(Polylines, LineEndsAndByteOrderMark) {
  TempDir dir;
  const std::string lf = "isoloft-polylines 1\nsize 10 10\nslice 0\ncontour\n1 1\n8 1\n8 8\nslice 2\n";
  isoloft::test::write_text(dir.file("lf.txt"), lf);
  const SliceStack want = read_polylines(dir.file("lf.txt"));
  auto with = [&](const std::string& eol, bool bom) {
    std::string t = bom ? "\xEF\xBB\xBF" : "";
    for (char c : lf) t += c == '\n' ? eol : std::string(1, c);
    return t;
  };
  for (const auto& [eol, bom] : {std::pair{std::string("\r"), false}, {std::string("\r\n"), false}, {std::string("\n"), true},
                                 {std::string("\r"), true}}) {
    const std::string path = dir.file("v.txt");
    isoloft::test::write_text(path, with(eol, bom));
    SCOPED_TRACE(std::string(eol == "\r" ? "CR" : eol == "\r\n" ? "CRLF" : "LF") + (bom ? " with BOM" : ""));
    expect_same_stack(read_polylines(path), want);
  }
  expect_error(dir.file("e.txt"), "isoloft-polylines 1\rsize 10 10\rslice 0\rcontour\r1 1\r8 x\r", 6, "expected two numbers");
}
