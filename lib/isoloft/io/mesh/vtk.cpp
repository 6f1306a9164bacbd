// Legacy VTK (.vtk) POLYDATA, file version 4.2 (read by VTK 5-9, ITK, meshio):
// binary (big-endian, as the format requires) or ASCII; cell data Normals
// (facet normals) and Label, point data Colors when coloured, and the
// patient space in the title line ("SPACE=LPS"), where 3D Slicer reads it;
// the labels' names as field data "label" and "label_name".
#include <cstdint>
#include <string>
#include <vector>

#include "isoloft/io/mesh/format.h"

namespace isoloft::detail {

namespace {

// The labels and their names as the dataset's field data, as VTK's legacy
// reader reads a string array: in ASCII one string a line, bytes outside
// printable ASCII and '%' as %XX; in binary each string after a big-endian
// length header whose top two bits give its size (11: 1 byte, 6-bit length;
// 10: 2 bytes, 14 bits; 01: 4 bytes, 30 bits; 00: 8 bytes).
void write_label_names(Out& o, const std::vector<LabelName>& names, bool ascii) {
  o.text("FIELD FieldData 2\nlabel 1 ", names.size(), " unsigned_int\n");
  for (const LabelName& l : names) ascii ? o.text(l.label, ' ') : o.bin_be(l.label);
  o.text("\nlabel_name 1 ", names.size(), " string\n");
  for (const LabelName& l : names) {
    const std::string& s = l.name;
    if (ascii) {
      static constexpr char kHex[] = "0123456789ABCDEF";
      for (const unsigned char c : s)
        c > ' ' && c < 0x7F && c != '%' ? o.text(char(c)) : o.text('%', kHex[c >> 4], kHex[c & 15]);
      o.text('\n');
      continue;
    }
    const std::uint64_t n = s.size();
    if (n < (1u << 6)) o.bin_be(std::uint8_t(0xC0u | n));
    else if (n < (1u << 14)) o.bin_be(std::uint16_t(0x8000u | n));
    else if (n < (1u << 30)) o.bin_be(std::uint32_t(0x40000000u | n));
    else o.bin_be(n);
    o.text(s);
  }
  if (!ascii) o.text('\n');
}

}  // namespace

void write_vtk(const std::string& /*path*/, Out& o, const MeshOut& mo) {
  const TriMesh& m = mo.mesh;
  const bool ascii = mo.ascii;
  o.text("# vtk DataFile Version 4.2\nwritten by isoloft", mo.space.empty() ? "" : " SPACE=", mo.space, '\n',
         ascii ? "ASCII" : "BINARY", "\nDATASET POLYDATA\n");
  if (mo.label_names && !mo.label_names->empty()) write_label_names(o, *mo.label_names, ascii);
  o.text("POINTS ", m.vertices.size(), " float\n");
  for (std::size_t i = 0; i < m.vertices.size(); ++i) {
    const Vec3f p = mo.vertices[i];
    ascii ? o.text(p.x(), ' ', p.y(), ' ', p.z(), '\n') : o.bin_be(p.x(), p.y(), p.z());
  }
  o.text(ascii ? "" : "\n", "POLYGONS ", m.triangles.size(), ' ', 4 * m.triangles.size(), '\n');
  for (const auto& t : m.triangles)
    ascii ? o.text("3 ", t[0], ' ', t[1], ' ', t[2], '\n') : o.bin_be(std::int32_t(3), t[0], t[1], t[2]);
  o.text(ascii ? "" : "\n", "CELL_DATA ", m.triangles.size(), "\nNORMALS Normals float\n");
  for (const auto& t : m.triangles) {
    const Vec3f n = facet_normal(mo.vertices[std::size_t(t[0])], mo.vertices[std::size_t(t[1])], mo.vertices[std::size_t(t[2])]);
    ascii ? o.text(n.x(), ' ', n.y(), ' ', n.z(), '\n') : o.bin_be(n.x(), n.y(), n.z());
  }
  o.text(ascii ? "" : "\n", "SCALARS Label unsigned_int 1\nLOOKUP_TABLE default\n");
  for (std::size_t t = 0; t < m.triangles.size(); ++t) ascii ? o.text(cell_label(mo, t), '\n') : o.bin_be(cell_label(mo, t));
  if (mo.colors) {
    // Binary colour scalars are bytes; ASCII ones are fractions of 1.
    o.text(ascii ? "" : "\n", "POINT_DATA ", m.vertices.size(), "\nCOLOR_SCALARS Colors 3\n");
    for (const Rgb& c : *mo.colors)
      ascii ? o.text(c.r / 255.0f, ' ', c.g / 255.0f, ' ', c.b / 255.0f, '\n') : o.bin(c.r, c.g, c.b);
  }
  if (!ascii) o.text('\n');
}

}  // namespace isoloft::detail
