#include "isoloft/io/mesh_io.h"

// OpenMesh is the independent reader: our files must load in a well-kept
// library, not only in our own reader. MeshIO.hh must come before the mesh type.
#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <filesystem>
#include <map>

#include "io/io_test_util.h"
#include "isoloft/core/error.h"

using isoloft::InputError;
using isoloft::ParamError;
using isoloft::read_mesh;
using isoloft::Rgb;
using isoloft::TriMesh;
using isoloft::Vec3f;
using isoloft::write_mesh;
using isoloft::test::TempDir;

namespace {

struct Case {
  const char* ext;
  bool ascii;
};
// Every format and flavour the writer produces.
const Case kCases[] = {{".ply", false}, {".ply", true}, {".obj", true},
                       {".stl", false}, {".stl", true}, {".off", true}};

std::string case_name(const Case& c) { return std::string(c.ext) + (c.ascii ? " ascii" : " binary"); }

bool keeps_indices(const Case& c) { return std::string(c.ext) != ".stl"; }  // STL has no shared vertices
bool keeps_colors(const Case& c) { return std::string(c.ext) != ".stl"; }

/// Regular octahedron with a few odd coordinates, outward CCW triangles.
TriMesh octahedron() {
  TriMesh m;
  m.vertices = {{1.25f, 0, 0}, {-1, 0, 0}, {0, 1.1f, 0}, {0, -1, 0.f}, {0, 0, 3.3333333f}, {0, 0, -1e-3f}};
  m.triangles = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  return m;
}

Vec3f scaled(const Vec3f& v, double s) { return (v.cast<double>() * s).cast<float>(); }

/// Same triangles with the same corner coordinates (times `scale`), in order;
/// with `same_indices` also the same indices and vertex array.
void expect_same_mesh(const TriMesh& got, const TriMesh& want, double scale, bool same_indices) {
  ASSERT_EQ(got.triangles.size(), want.triangles.size());
  for (std::size_t t = 0; t < want.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      const auto gi = got.triangles[t][std::size_t(k)], wi = want.triangles[t][std::size_t(k)];
      ASSERT_GE(gi, 0);
      ASSERT_LT(std::size_t(gi), got.vertices.size());
      // Exact: writers print the shortest text that reads back to the same float.
      ASSERT_EQ(got.vertices[std::size_t(gi)], scaled(want.vertices[std::size_t(wi)], scale))
          << "triangle " << t << " corner " << k;
      if (same_indices) {
        ASSERT_EQ(gi, wi) << "triangle " << t << " corner " << k;
      }
    }
  if (same_indices) {
    ASSERT_EQ(got.vertices.size(), want.vertices.size());
  }
}

}  // namespace

TEST(MeshIo, RoundTripEveryFormatScaled) {
  TempDir dir;
  const TriMesh m = octahedron();
  constexpr double scale = 0.8;  // e.g. pixel size in mm
  for (const Case& c : kCases) {
    SCOPED_TRACE(case_name(c));
    const std::string path = dir.file(std::string("oct") + (c.ascii ? "_a" : "_b") + c.ext);
    write_mesh(path, m, scale, nullptr, c.ascii);
    std::vector<Rgb> colors{{1, 2, 3}};
    const TriMesh r = read_mesh(path, &colors);
    expect_same_mesh(r, m, scale, keeps_indices(c));
    EXPECT_EQ(r.vertices.size(), m.vertices.size()) << "STL welding must restore the shared vertices";
    EXPECT_TRUE(colors.empty()) << "no colours were written";
  }
  EXPECT_EQ(dir.entries().size(), std::size(kCases)) << "temp files left behind";
}

TEST(MeshIo, ColoursRoundTrip) {
  TempDir dir;
  const TriMesh m = octahedron();
  std::vector<Rgb> colors;
  for (std::size_t i = 0; i < m.vertices.size(); ++i)
    colors.push_back({std::uint8_t(40 * i), std::uint8_t(255 - 17 * i), std::uint8_t(i == 2 ? 255 : 0)});
  for (const Case& c : kCases) {
    if (!keeps_colors(c)) continue;
    SCOPED_TRACE(case_name(c));
    const std::string path = dir.file(std::string("col") + (c.ascii ? "_a" : "_b") + c.ext);
    write_mesh(path, m, 1.0, &colors, c.ascii);
    std::vector<Rgb> got;
    const TriMesh r = read_mesh(path, &got);
    expect_same_mesh(r, m, 1.0, true);
    ASSERT_EQ(got.size(), colors.size());
    for (std::size_t i = 0; i < colors.size(); ++i) EXPECT_EQ(got[i], colors[i]) << "vertex " << i;
  }
}

TEST(MeshIo, OpenMeshReadsOurFiles) {
  using OMesh = OpenMesh::TriMesh_ArrayKernelT<>;
  TempDir dir;
  const TriMesh m = octahedron();
  std::vector<Rgb> colors(m.vertices.size(), Rgb{200, 100, 50});
  constexpr double scale = 2.5;
  for (const Case& c : kCases) {
    SCOPED_TRACE(case_name(c));
    const std::string path = dir.file(std::string("om") + (c.ascii ? "_a" : "_b") + c.ext);
    write_mesh(path, m, scale, keeps_colors(c) ? &colors : nullptr, c.ascii);
    OMesh om;
    om.request_vertex_colors();
    OpenMesh::IO::Options opt;
    if (keeps_colors(c) && std::string(c.ext) != ".obj") opt += OpenMesh::IO::Options::VertexColor;
    ASSERT_TRUE(OpenMesh::IO::read_mesh(om, path, opt)) << path;
    ASSERT_EQ(om.n_vertices(), m.vertices.size());
    ASSERT_EQ(om.n_faces(), m.triangles.size());
    // Same set of positions (OpenMesh may reorder STL vertices).
    std::multiset<std::array<float, 3>> want, got;
    for (const auto& v : m.vertices) {
      const Vec3f s = scaled(v, scale);
      want.insert({s.x(), s.y(), s.z()});
    }
    for (const auto vh : om.vertices()) {
      const auto p = om.point(vh);
      got.insert({p[0], p[1], p[2]});
    }
    EXPECT_EQ(got, want);
    EXPECT_EQ(opt.check(OpenMesh::IO::Options::VertexColor), keeps_colors(c) && std::string(c.ext) != ".obj")
        << "OpenMesh did not find the colours";
    if (opt.check(OpenMesh::IO::Options::VertexColor)) {
      for (const auto vh : om.vertices()) {
        const auto col = om.color(vh);
        EXPECT_EQ(int(col[0]), 200) << "vertex " << vh.idx();
        EXPECT_EQ(int(col[2]), 50) << "vertex " << vh.idx();
      }
    }
  }
}

TEST(MeshIo, ReadsForeignFlavours) {
  TempDir dir;
  // ASCII PLY: double coordinates, int list counts, a quad, an extra element and property.
  isoloft::test::write_text(dir.file("q.ply"),
                            "ply\nformat ascii 1.0\ncomment hand written\nelement vertex 4\n"
                            "property double x\nproperty double y\nproperty double z\nproperty float confidence\n"
                            "element face 1\nproperty int flags\nproperty list int uint vertex_index\n"
                            "element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n"
                            "0 0 0 1\n1 0 0 1\n1 1 0 1\n0 1 0.5 1\n7 4 0 1 2 3\n0 1\n");
  TriMesh q = read_mesh(dir.file("q.ply"));
  ASSERT_EQ(q.vertices.size(), 4u);
  EXPECT_EQ(q.vertices[3], Vec3f(0, 1, 0.5f));
  const std::vector<std::array<std::int32_t, 3>> fan{{0, 1, 2}, {0, 2, 3}};
  EXPECT_EQ(q.triangles, fan);

  // Binary big-endian PLY with ushort list counts.
  std::string be =
      "ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list ushort int vertex_indices\nend_header\n";
  auto put_be = [&](std::uint32_t u, int bytes) {
    for (int b = bytes - 1; b >= 0; --b) be.push_back(char((u >> (8 * b)) & 0xFF));
  };
  for (float f : {0.f, 0.f, 0.f, 2.f, 0.f, 0.f, 0.f, 2.f, 0.f}) put_be(std::bit_cast<std::uint32_t>(f), 4);
  put_be(3, 2);
  for (std::uint32_t i : {0u, 1u, 2u}) put_be(i, 4);
  isoloft::test::write_text(dir.file("be.ply"), be);
  const TriMesh b = read_mesh(dir.file("be.ply"));
  ASSERT_EQ(b.triangles.size(), 1u);
  EXPECT_EQ(b.vertices[2], Vec3f(0, 2, 0));

  // OBJ: comments, v/vt/vn references, negative indices, a quad, ignored records.
  isoloft::test::write_text(dir.file("q.obj"),
                            "# hand written\nmtllib x.mtl\no thing\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                            "vt 0 0\nvn 0 0 1\ns off\nf 1/1/1 2/1/1 3/1/1 4/1/1\nf -4//1 -2//1 -1//1\n");
  const TriMesh o = read_mesh(dir.file("q.obj"));
  const std::vector<std::array<std::int32_t, 3>> obj_tris{{0, 1, 2}, {0, 2, 3}, {0, 2, 3}};
  EXPECT_EQ(o.triangles, obj_tris);

  // ASCII STL from another tool: shared corners are welded.
  isoloft::test::write_text(dir.file("t.stl"),
                            "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n"
                            "endloop\nendfacet\nfacet normal 0 0 1\nouter loop\nvertex 1 0 0\nvertex 1 1 0\n"
                            "vertex -0 1 0\nendloop\nendfacet\nendsolid t\n");
  const TriMesh s = read_mesh(dir.file("t.stl"));
  EXPECT_EQ(s.vertices.size(), 4u) << "-0 and 0 are the same position";
  const std::vector<std::array<std::int32_t, 3>> stl_tris{{0, 1, 2}, {1, 3, 2}};
  EXPECT_EQ(s.triangles, stl_tris);

  // OFF with comments, counts on the header line, a quad and face colours.
  isoloft::test::write_text(dir.file("q.off"),
                            "OFF 4 1 0\n# comment\n0 0 0\n1 0 0\n\n1 1 0\n0 1 0\n4 0 1 2 3 255 0 0\n");
  EXPECT_EQ(read_mesh(dir.file("q.off")).triangles, fan);
  // Uppercase extension.
  std::filesystem::copy_file(dir.file("q.off"), dir.file("Q2.OFF"));
  EXPECT_EQ(read_mesh(dir.file("Q2.OFF")).triangles, fan);
}

TEST(MeshIo, CorruptFilesThrowInputError) {
  TempDir dir;
  const TriMesh m = octahedron();
  write_mesh(dir.file("ok.ply"), m);
  write_mesh(dir.file("ok.stl"), m);
  const auto ply = isoloft::test::read_bytes(dir.file("ok.ply"));
  const auto stl = isoloft::test::read_bytes(dir.file("ok.stl"));
  std::vector<std::pair<std::string, std::string>> bad = {
      {"missing.ply", ""},
      {"notply.ply", "hello\n"},
      {"noend.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"},
      {"badfmt.ply", "ply\nformat binary_middle_endian 1.0\nend_header\n"},
      {"noxyz.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n"},
      {"range.ply",
       "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
       "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n"},
      {"twoverts.ply",
       "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
       "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n"},
      {"badnum.ply",
       "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
       "end_header\n0 zero 0\n"},
      {"range.obj", "v 0 0 0\nv 1 0 0\nf 1 2 3\n"},
      {"zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n"},
      {"shortv.obj", "v 0 0\n"},
      {"notstl.stl", "hello"},
      {"open.stl", "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n"},
      {"notoff.off", "PLY\n"},
      {"short.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n"},
      {"range.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 9\n"},
      {"mesh.xyz", "0 0 0\n"},
  };
  for (const auto& [name, text] : bad)
    if (!text.empty()) isoloft::test::write_text(dir.file(name), text);
  // Binary files cut short or with a lying count.
  isoloft::test::write_bytes(dir.file("cut.ply"), {ply.begin(), ply.end() - 7});
  isoloft::test::write_bytes(dir.file("cut.stl"), {stl.begin(), stl.end() - 20});
  bad.push_back({"cut.ply", ""});
  bad.push_back({"cut.stl", ""});
  for (const auto& entry : bad) {
    const std::string path = dir.file(entry.first);
    try {
      (void)read_mesh(path);
      ADD_FAILURE() << "accepted " << entry.first;
    } catch (const InputError& e) {
      EXPECT_EQ(e.file, path) << e.what();
    }
  }
}

// The VTK formats are written, not read: their headers and counts as VTK
// expects them (python3-vtk9 reads them back in tests/python/test_outputs.py).
TEST(MeshIo, VtkFormatsAreWrittenWithLabelsAndSpace) {
  TempDir dir;
  const TriMesh m = octahedron();
  isoloft::MeshWriteOptions o;
  o.label = 7;
  o.frame = isoloft::PatientFrame{};
  write_mesh(dir.file("m.vtp"), m, o);
  write_mesh(dir.file("m.vtk"), m, o);
  const std::string vtp = isoloft::test::read_text(dir.file("m.vtp")), vtk = isoloft::test::read_text(dir.file("m.vtk"));
  EXPECT_NE(vtp.find("NumberOfPoints=\"6\""), std::string::npos);
  EXPECT_NE(vtp.find("NumberOfPolys=\"8\""), std::string::npos);
  EXPECT_NE(vtp.find("Name=\"SPACE\""), std::string::npos);  // "LPS" as character codes
  EXPECT_NE(vtp.find(" 76 80 83 0"), std::string::npos);
  EXPECT_EQ(vtk.rfind("# vtk DataFile Version 4.2\nwritten by isoloft SPACE=LPS\nBINARY\n", 0), 0u);
  EXPECT_NE(vtk.find("POLYGONS 8 32\n"), std::string::npos);
  EXPECT_NE(vtk.find("SCALARS Label unsigned_int 1\n"), std::string::npos);
  // The last label, big-endian, ends the file's data.
  EXPECT_EQ(vtk.substr(vtk.size() - 5), std::string("\0\0\0\x07\n", 5));
  try {
    (void)read_mesh(dir.file("m.vtp"));
    ADD_FAILURE() << "read a .vtp";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("written, not read"), std::string::npos) << e.what();
  }
  std::vector<std::uint32_t> wrong(3);
  o.triangle_labels = &wrong;
  EXPECT_THROW(write_mesh(dir.file("w.vtp"), m, o), ParamError);
}

TEST(MeshIo, WriterParameterErrors) {
  TempDir dir;
  const TriMesh m = octahedron();
  EXPECT_THROW(write_mesh(dir.file("x.vtu"), m), ParamError);
  EXPECT_THROW(write_mesh(dir.file("x"), m), ParamError);
  EXPECT_THROW(write_mesh(dir.file("x.ply"), m, 0.0), ParamError);
  const std::vector<Rgb> too_few(2);
  EXPECT_THROW(write_mesh(dir.file("x.ply"), m, 1.0, &too_few), ParamError);
  TriMesh broken = m;
  broken.triangles.push_back({0, 1, 99});
  EXPECT_THROW(write_mesh(dir.file("x.ply"), broken), isoloft::Error);
  EXPECT_TRUE(dir.entries().empty()) << "left: " << dir.entries().front();
}

TEST(MeshIo, EmptyMeshRoundTrips) {
  TempDir dir;
  for (const Case& c : kCases) {
    SCOPED_TRACE(case_name(c));
    const std::string path = dir.file(std::string("e") + (c.ascii ? "_a" : "_b") + c.ext);
    write_mesh(path, TriMesh{}, 1.0, nullptr, c.ascii);
    const TriMesh r = read_mesh(path);
    EXPECT_TRUE(r.triangles.empty());
    EXPECT_TRUE(r.vertices.empty());
  }
}

TEST(MeshIo, MergeMeshesOffsetsIndicesAndColours) {
  const TriMesh a = octahedron();
  TriMesh b;
  b.vertices = {{5, 5, 5}, {6, 5, 5}, {5, 6, 5}};
  b.triangles = {{0, 1, 2}};
  std::vector<Rgb> cols;
  const TriMesh m = isoloft::merge_meshes({a, b}, {{255, 0, 0}, {0, 0, 255}}, &cols);
  ASSERT_EQ(m.vertices.size(), 9u);
  ASSERT_EQ(m.triangles.size(), 9u);
  EXPECT_EQ(m.triangles.back(), (std::array<std::int32_t, 3>{6, 7, 8}));
  EXPECT_EQ(m.vertices[7], Vec3f(6, 5, 5));
  ASSERT_EQ(cols.size(), 9u);
  EXPECT_EQ(cols[5], (Rgb{255, 0, 0}));
  EXPECT_EQ(cols[6], (Rgb{0, 0, 255}));
  EXPECT_THROW(isoloft::merge_meshes({a, b}, {{1, 1, 1}}), ParamError);
}

RC_GTEST_PROP(MeshIoProperty, RandomSoupsRoundTripEveryFormat, ()) {
  // Arbitrary triangle soups: repeated and degenerate triangles, unused and
  // duplicated vertices, non-manifold edges. Coordinates are floats of mixed
  // magnitude to exercise the shortest-text formatting.
  const int nv = *rc::gen::inRange(1, 30);
  TriMesh m;
  for (int i = 0; i < nv; ++i) {
    const auto c = *rc::gen::container<std::vector<int>>(3, rc::gen::inRange(-100000, 100000));
    m.vertices.emplace_back(float(c[0]) * 0.0137f, float(c[1]) * 3.1f, float(c[2]) * 1e-4f);
  }
  const int nt = *rc::gen::inRange(0, 40);
  for (int t = 0; t < nt; ++t)
    m.triangles.push_back({*rc::gen::inRange(0, nv), *rc::gen::inRange(0, nv), *rc::gen::inRange(0, nv)});
  const double scale = *rc::gen::element(1.0, 0.8, 2.5, 1e-3);
  TempDir dir;
  for (const Case& c : kCases) {
    const std::string path = dir.file(std::string("r") + (c.ascii ? "_a" : "_b") + c.ext);
    write_mesh(path, m, scale, nullptr, c.ascii);
    const TriMesh r = read_mesh(path);
    RC_ASSERT(r.triangles.size() == m.triangles.size());
    for (std::size_t t = 0; t < m.triangles.size(); ++t)
      for (std::size_t k = 0; k < 3; ++k) {
        RC_ASSERT(r.vertices[std::size_t(r.triangles[t][k])] ==
                  scaled(m.vertices[std::size_t(m.triangles[t][k])], scale));
        if (keeps_indices(c)) RC_ASSERT(r.triangles[t][k] == m.triangles[t][k]);
      }
  }
}

RC_GTEST_PROP(MeshIoProperty, DamagedFilesThrowInputErrorOrReadValidMeshes, ()) {
  // Random byte edits and truncations of valid files: the reader may accept
  // the result, but then every index must be valid; otherwise InputError.
  // Anything else (crash, other exception, sanitizer report) fails.
  const Case c = *rc::gen::elementOf(std::vector<Case>(std::begin(kCases), std::end(kCases)));
  TempDir dir;
  const std::string path = dir.file(std::string("f") + c.ext);
  const TriMesh m = octahedron();
  std::vector<Rgb> colors(m.vertices.size(), Rgb{1, 2, 3});
  write_mesh(path, m, 1.0, keeps_colors(c) ? &colors : nullptr, c.ascii);
  auto bytes = isoloft::test::read_bytes(path);
  const int edits = *rc::gen::inRange(1, 6);
  for (int e = 0; e < edits; ++e) {
    const std::size_t at = *rc::gen::inRange<std::size_t>(0, bytes.size());
    bytes[at] = *rc::gen::arbitrary<unsigned char>();
  }
  if (*rc::gen::arbitrary<bool>()) bytes.resize(*rc::gen::inRange<std::size_t>(0, bytes.size()));
  isoloft::test::write_bytes(path, bytes);
  try {
    const TriMesh r = read_mesh(path);
    for (const auto& t : r.triangles)
      for (const auto i : t) RC_ASSERT(i >= 0 && std::size_t(i) < r.vertices.size());
  } catch (const InputError& e) {
    RC_ASSERT(e.file == path);
  }
}

// The labels' names as VTK field data: "label" (UInt32) and "label_name"
// (String), one tuple per label, in the byte layouts VTK's readers take
// (python3-vtk9 reads them back in tests/python/test_rtstruct_labels.py).
TEST(MeshIo, VtkFormatsCarryLabelNamesAsFieldData) {
  TempDir dir;
  const TriMesh m = octahedron();
  isoloft::MeshWriteOptions o;
  o.label_names = {{5, "Precentral L"}, {70000, "\xC3\x85%"}, {9, ""}};  // a blank, a non-ASCII byte, '%', an empty name
  const std::string long_name(70, 'x');                                 // over a 1-byte length header (63)
  o.label_names.push_back({11, long_name});
  write_mesh(dir.file("m.vtp"), m, o);
  const std::string vtp = isoloft::test::read_text(dir.file("m.vtp"));
  EXPECT_NE(vtp.find("<DataArray type=\"UInt32\" Name=\"label\" NumberOfTuples=\"4\" format=\"ascii\">\n        5 70000 9 11\n"),
            std::string::npos)
      << vtp.substr(0, 600);
  // Each name's bytes, then 0: "Precentral L", "Å%" (UTF-8 bytes), "", 70 'x'.
  std::string codes = " 80 114 101 99 101 110 116 114 97 108 32 76 0 195 133 37 0 0";
  for (int i = 0; i < 70; ++i) codes += " 120";
  EXPECT_NE(vtp.find("Name=\"label_name\" NumberOfTuples=\"4\" format=\"ascii\">\n       " + codes + " 0\n"), std::string::npos)
      << vtp.substr(0, 900);

  o.ascii = true;
  write_mesh(dir.file("a.vtk"), m, o);
  const std::string ascii = isoloft::test::read_text(dir.file("a.vtk"));
  EXPECT_NE(ascii.find("DATASET POLYDATA\nFIELD FieldData 2\nlabel 1 4 unsigned_int\n5 70000 9 11 \n"
                       "label_name 1 4 string\nPrecentral%20L\n%C3%85%25\n\n" + long_name + "\nPOINTS 6 float\n"),
            std::string::npos)
      << ascii.substr(0, 400);
  o.ascii = false;
  write_mesh(dir.file("b.vtk"), m, o);
  const std::string binary = isoloft::test::read_text(dir.file("b.vtk"));
  const std::string field = std::string("FIELD FieldData 2\nlabel 1 4 unsigned_int\n") +
                            std::string("\0\0\0\x05\0\x01\x11\x70\0\0\0\x09\0\0\0\x0B\n", 17) + "label_name 1 4 string\n" +
                            "\xCC" "Precentral L" "\xC3\xC3\x85%" "\xC0" + std::string("\x80\x46", 2) + long_name +
                            "\nPOINTS 6 float\n";
  EXPECT_NE(binary.find(field), std::string::npos);
  // Without names: no field data beyond SPACE (files of unnamed labels keep their bytes).
  o.label_names.clear();
  write_mesh(dir.file("n.vtk"), m, o);
  EXPECT_EQ(isoloft::test::read_text(dir.file("n.vtk")).find("FIELD"), std::string::npos);
}

// A frame placed while writing (no copy of the mesh) gives the bytes of the
// mesh placed first by in_patient_space() and written as it is (the header's
// space name aside): PLY, OBJ, OFF and STL, LPS and RAS, the identity, a
// rotated frame with an origin and a mirrored one (that one is copied, its
// triangles reversed), with a -0 coordinate (origin + axes * p makes it +0).
TEST(MeshIo, FramePlacedWhileWritingGivesThePlacedMeshBytes) {
  TempDir dir;
  TriMesh m = octahedron();
  m.vertices[0].x() = -0.0f;
  isoloft::PatientFrame rotated;
  rotated.axes << 0.0, -0.7, 0.1, 0.7, 0.0, 0.0, 0.0, 0.05, 3.0;
  rotated.origin = {-120.25, 33.5, 0.0};
  isoloft::PatientFrame mirrored = rotated;
  mirrored.axes.col(2) *= -1.0;
  // The file without its space name: PLY's and OBJ's / OFF's comment line, STL's 80-byte header.
  auto body = [](const std::string& text, const std::string& ext) {
    if (ext == ".stl") return text.substr(80);
    const std::size_t at = text.find("SPACE=");
    if (at == std::string::npos) return text;
    const std::size_t line = text.rfind('\n', at) + 1, end = text.find('\n', at) + 1;
    return text.substr(0, line) + text.substr(end);
  };
  const std::vector<isoloft::PatientFrame> frames = {isoloft::PatientFrame{}, rotated, mirrored};
  for (std::size_t f = 0; f < frames.size(); ++f)
    for (const bool ras : {false, true})
      for (const std::string ext : {".ply", ".obj", ".off", ".stl"}) {
        isoloft::MeshWriteOptions framed;
        framed.frame = frames[f];
        framed.ras = ras;
        write_mesh(dir.file("framed" + ext), m, framed);
        write_mesh(dir.file("placed" + ext), isoloft::in_patient_space(m, frames[f], ras), isoloft::MeshWriteOptions{});
        const std::string got = isoloft::test::read_text(dir.file("framed" + ext));
        EXPECT_NE(got.find(ras ? "SPACE=RAS" : "SPACE=LPS"), std::string::npos) << "frame " << f << ' ' << ext;
        EXPECT_EQ(body(got, ext), body(isoloft::test::read_text(dir.file("placed" + ext)), ext))
            << "frame " << f << ' ' << ext << " ras " << ras;
      }
}
