// Wavefront OBJ: "v x y z [r g b]" and "f" lines; v/vt/vn and negative indices read.
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <string_view>
#include <unordered_map>

#include "isoloft/io/mesh/format.h"
#include "isoloft/io/text.h"

namespace isoloft::detail {

void write_obj(const std::string& /*path*/, Out& o, const MeshOut& mo) {
  const TriMesh& m = mo.mesh;
  const Scaled& v = mo.vertices;
  const std::vector<Rgb>* colors = mo.colors;
  if (!mo.space.empty()) o.text("# SPACE=", mo.space, '\n');
  o.text("# written by isoloft\n");
  for (std::size_t i = 0; i < m.vertices.size(); ++i) {
    const Vec3f p = v[i];
    o.text("v ", p.x(), ' ', p.y(), ' ', p.z());
    if (colors) {
      const Rgb c = (*colors)[i];
      for (std::uint8_t ch : {c.r, c.g, c.b}) o.text(' ', float(ch) / 255.0f);
    }
    o.text('\n');
  }
  for (const auto& t : m.triangles) {
    o.text("f ", t[0] + 1, ' ', t[1] + 1, ' ', t[2] + 1, '\n');
  }
}

TriMesh read_obj(const std::string& path, const std::vector<unsigned char>& bytes, std::vector<Rgb>* colors) {
  Lines lines(bytes.data(), bytes.data() + bytes.size());
  std::string_view line;
  std::vector<std::string_view> tok;
  TriMesh m;
  std::vector<Rgb> cols;
  bool all_colored = true;
  std::vector<long long> poly;
  while (lines.next(line)) {
    split_tokens(line, tok, true);
    if (tok.empty()) continue;
    auto where = [&] { return at_line(lines.number()); };  // built only on error
    if (tok[0] == "v") {
      float c[6];
      const std::size_t n = tok.size() - 1;
      if (n < 3 || n > 7) throw InputError(path, where() + "expected 3 coordinates after 'v'");
      for (std::size_t k = 0; k < std::min<std::size_t>(n, 6); ++k)
        if (!parse_number(tok[k + 1], c[k]))
          throw InputError(path, where() + "bad number '" + std::string(tok[k + 1]) + "'");
      m.vertices.emplace_back(c[0], c[1], c[2]);
      if (n >= 6) {
        cols.push_back({color_component(c[3], true), color_component(c[4], true), color_component(c[5], true)});
      } else {
        all_colored = false;
      }
    } else if (tok[0] == "f") {
      poly.clear();
      for (std::size_t k = 1; k < tok.size(); ++k) {
        const std::string_view idx = tok[k].substr(0, tok[k].find('/'));
        long long i = 0;
        if (!parse_number(idx, i) || i == 0)
          throw InputError(path, where() + "bad vertex index '" + std::string(tok[k]) + "'");
        i = i > 0 ? i - 1 : (long long)m.vertices.size() + i;  // negative: relative to the latest vertex
        if (i < 0 || i >= (long long)m.vertices.size())
          throw InputError(path, where() + "vertex index " + std::string(idx) + " out of range");
        poly.push_back(i);
      }
      add_fan(m, poly, path, where);
    }
    // vt, vn, g, o, s, usemtl, mtllib, l, ...: not needed for a surface
  }
  if (colors) *colors = (all_colored && !m.vertices.empty()) ? std::move(cols) : std::vector<Rgb>{};
  return m;
}

}  // namespace isoloft::detail
