// VTK XML PolyData (.vtp): binary, the arrays appended raw after the XML
// (UInt64 byte-count headers, little-endian), as vtkXMLPolyDataReader reads
// them; cell data Normals (facet normals) and Label, point data Colors when
// coloured, and the patient space as the field-data string SPACE the way
// 3D Slicer reads it; the labels' names as field data "label" and
// "label_name". ASCII (`ascii`) writes every array inline.
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "isoloft/io/mesh/format.h"

namespace isoloft::detail {

namespace {

// One data array: its XML attributes, its byte count, and how to emit its values.
struct Array {
  const char* type;  // Float32, Int32, UInt32, UInt8
  const char* name;  // "" for the unnamed topology arrays
  int components;
  std::uint64_t count;  // values (tuples x components)
  std::uint64_t value_bytes;
};

void open_array(Out& o, const Array& a, bool ascii, std::uint64_t& offset) {
  o.text("        <DataArray type=\"", a.type, "\"");
  if (*a.name) o.text(" Name=\"", a.name, "\"");
  if (a.components > 1) o.text(" NumberOfComponents=\"", a.components, "\"");
  if (ascii) {
    o.text(" format=\"ascii\">\n");
  } else {
    o.text(" format=\"appended\" offset=\"", offset, "\"/>\n");
    offset += sizeof(std::uint64_t) + a.count * a.value_bytes;
  }
}

void close_array(Out& o, bool ascii) {
  if (ascii) o.text("\n        </DataArray>\n");
}

}  // namespace

void write_vtp(const std::string& /*path*/, Out& o, const MeshOut& mo) {
  const TriMesh& m = mo.mesh;
  const auto nv = std::uint64_t(m.vertices.size()), nt = std::uint64_t(m.triangles.size());
  const bool ascii = mo.ascii;
  const Array points{"Float32", "Points", 3, 3 * nv, 4}, connectivity{"Int32", "connectivity", 1, 3 * nt, 4},
      offsets{"Int32", "offsets", 1, nt, 4}, normals{"Float32", "Normals", 3, 3 * nt, 4},
      labels{"UInt32", "Label", 1, nt, 4}, colors{"UInt8", "Colors", 3, 3 * nv, 1};
  // The arrays in file order, with a writer of their values each.
  auto emit_points = [&] {
    for (std::size_t i = 0; i < m.vertices.size(); ++i) {
      const Vec3f p = mo.vertices[i];
      ascii ? o.text(p.x(), ' ', p.y(), ' ', p.z(), '\n') : o.bin(p.x(), p.y(), p.z());
    }
  };
  auto emit_connectivity = [&] {
    for (const auto& t : m.triangles) ascii ? o.text(t[0], ' ', t[1], ' ', t[2], '\n') : o.bin(t[0], t[1], t[2]);
  };
  auto emit_offsets = [&] {
    for (std::uint64_t t = 1; t <= nt; ++t) ascii ? o.text(std::int32_t(3 * t), '\n') : o.bin(std::int32_t(3 * t));
  };
  auto emit_normals = [&] {
    for (const auto& t : m.triangles) {
      const Vec3f n = facet_normal(mo.vertices[std::size_t(t[0])], mo.vertices[std::size_t(t[1])], mo.vertices[std::size_t(t[2])]);
      ascii ? o.text(n.x(), ' ', n.y(), ' ', n.z(), '\n') : o.bin(n.x(), n.y(), n.z());
    }
  };
  auto emit_labels = [&] {
    for (std::size_t t = 0; t < m.triangles.size(); ++t) ascii ? o.text(cell_label(mo, t), '\n') : o.bin(cell_label(mo, t));
  };
  auto emit_colors = [&] {
    for (const Rgb& c : *mo.colors) ascii ? o.text(int(c.r), ' ', int(c.g), ' ', int(c.b), '\n') : o.bin(c.r, c.g, c.b);
  };
  struct Part {
    const Array& array;
    std::function<void()> emit;
  };
  o.text("<?xml version=\"1.0\"?>\n<!-- written by isoloft -->\n",
         "<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n  <PolyData>\n");
  const bool named = mo.label_names && !mo.label_names->empty();
  if (!mo.space.empty() || named) {
    // A string array: each string's bytes and a terminating 0, as character codes.
    auto strings = [&](const char* name, std::size_t n, const std::function<const std::string&(std::size_t)>& at) {
      o.text("      <DataArray type=\"String\" Name=\"", name, "\" NumberOfTuples=\"", n, "\" format=\"ascii\">\n       ");
      for (std::size_t i = 0; i < n; ++i) {
        for (const unsigned char c : at(i)) o.text(' ', int(c));
        o.text(" 0");
      }
      o.text("\n      </DataArray>\n");
    };
    o.text("    <FieldData>\n");
    if (!mo.space.empty()) strings("SPACE", 1, [&](std::size_t) -> const std::string& { return mo.space; });
    if (named) {
      const std::vector<LabelName>& names = *mo.label_names;
      o.text("      <DataArray type=\"UInt32\" Name=\"label\" NumberOfTuples=\"", names.size(), "\" format=\"ascii\">\n       ");
      for (const LabelName& l : names) o.text(' ', l.label);
      o.text("\n      </DataArray>\n");
      strings("label_name", names.size(), [&](std::size_t i) -> const std::string& { return names[i].name; });
    }
    o.text("    </FieldData>\n");
  }
  o.text("    <Piece NumberOfPoints=\"", nv, "\" NumberOfVerts=\"0\" NumberOfLines=\"0\" NumberOfStrips=\"0\" NumberOfPolys=\"", nt,
         "\">\n");
  std::uint64_t offset = 0;
  std::vector<Part> appended;
  auto section = [&](const char* tag, const char* attributes, std::initializer_list<Part> parts) {
    o.text("      <", tag, attributes, ">\n");
    for (const Part& p : parts) {
      open_array(o, p.array, ascii, offset);
      if (ascii) {
        p.emit();
        close_array(o, ascii);
      } else {
        appended.push_back(p);
      }
    }
    o.text("      </", tag, ">\n");
  };
  if (mo.colors) section("PointData", " Scalars=\"Colors\"", {{colors, emit_colors}});
  section("CellData", " Normals=\"Normals\" Scalars=\"Label\"", {{normals, emit_normals}, {labels, emit_labels}});
  section("Points", "", {{points, emit_points}});
  section("Polys", "", {{connectivity, emit_connectivity}, {offsets, emit_offsets}});
  o.text("    </Piece>\n  </PolyData>\n");
  if (!ascii) {
    o.text("  <AppendedData encoding=\"raw\">\n   _");
    for (const Part& p : appended) {
      o.bin(std::uint64_t(p.array.count * p.array.value_bytes));
      p.emit();
    }
    o.text("\n  </AppendedData>\n");
  }
  o.text("</VTKFile>\n");
}

}  // namespace isoloft::detail
