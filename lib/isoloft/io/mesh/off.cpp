// OFF / COFF (Geomview).
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

void write_off(const std::string& /*path*/, Out& o, const MeshOut& mo) {
  const TriMesh& m = mo.mesh;
  const Scaled& v = mo.vertices;
  const std::vector<Rgb>* colors = mo.colors;
  o.text(colors ? "COFF\n" : "OFF\n");
  if (!mo.space.empty()) o.text("# SPACE=", mo.space, '\n');
  o.text(m.vertices.size(), ' ', m.triangles.size(), " 0\n");
  for (std::size_t i = 0; i < m.vertices.size(); ++i) {
    const Vec3f p = v[i];
    o.text(p.x(), ' ', p.y(), ' ', p.z());
    if (colors) {
      const Rgb c = (*colors)[i];
      o.text(' ', int(c.r), ' ', int(c.g), ' ', int(c.b), " 255");
    }
    o.text('\n');
  }
  for (const auto& t : m.triangles) {
    o.text("3 ", t[0], ' ', t[1], ' ', t[2], '\n');
  }
}

TriMesh read_off(const std::string& path, const std::vector<unsigned char>& bytes, std::vector<Rgb>* colors) {
  Lines lines(bytes.data(), bytes.data() + bytes.size());
  std::string_view line;
  std::vector<std::string_view> tok;
  auto next_tokens = [&]() {
    while (lines.next(line)) {
      split_tokens(line, tok, true);
      if (!tok.empty()) return true;
    }
    return false;
  };
  if (!next_tokens()) throw InputError(path, "empty OFF file");
  const std::string_view key = tok[0];
  const bool has_normals = key == "NOFF" || key == "CNOFF";
  const bool has_colors = key == "COFF" || key == "CNOFF";
  if (key != "OFF" && !has_normals && !has_colors)
    throw InputError(path, "not an OFF file (header '" + std::string(key) + "')");
  std::vector<std::string_view> counts(tok.begin() + 1, tok.end());
  if (counts.empty()) {
    if (!next_tokens()) throw InputError(path, "OFF file lacks the vertex/face counts");
    counts = tok;
  }
  long long nv = 0, nf = 0;
  if (counts.size() < 2 || !parse_number(counts[0], nv) || !parse_number(counts[1], nf) || nv < 0 || nf < 0)
    throw InputError(path, at_line(lines.number()) + "bad vertex/face counts");
  TriMesh m;
  std::vector<Rgb> cols;
  const std::size_t cap = bytes.size() / 4;  // a vertex or face line takes at least ~6 bytes
  m.vertices.reserve(std::min<std::size_t>(std::size_t(nv), cap));
  const std::size_t need = 3 + (has_normals ? 3 : 0);
  for (long long i = 0; i < nv; ++i) {
    if (!next_tokens())
      throw InputError(path, "OFF file ends after " + std::to_string(i) + " of " + std::to_string(nv) + " vertices");
    auto where = [&] { return at_line(lines.number()); };  // built only on error
    float c[3];
    if (tok.size() < need) throw InputError(path, where() + "expected " + std::to_string(need) + " numbers");
    for (int k = 0; k < 3; ++k)
      if (!parse_number(tok[std::size_t(k)], c[k]))
        throw InputError(path, where() + "bad number '" + std::string(tok[std::size_t(k)]) + "'");
    m.vertices.emplace_back(c[0], c[1], c[2]);
    if (has_colors) {
      if (tok.size() < need + 3) throw InputError(path, where() + "COFF vertex lacks a colour");
      double rgb[3];
      bool unit = false;
      for (int k = 0; k < 3; ++k) {
        const std::string_view t = tok[need + std::size_t(k)];
        if (!parse_number(t, rgb[k])) throw InputError(path, where() + "bad colour '" + std::string(t) + "'");
        unit = unit || t.find('.') != std::string_view::npos;  // 0..1 floats vs 0..255 integers
      }
      cols.push_back({color_component(rgb[0], unit), color_component(rgb[1], unit), color_component(rgb[2], unit)});
    }
  }
  std::vector<long long> poly;
  for (long long f = 0; f < nf; ++f) {
    if (!next_tokens())
      throw InputError(path, "OFF file ends after " + std::to_string(f) + " of " + std::to_string(nf) + " faces");
    auto where = [&] { return at_line(lines.number()); };  // built only on error
    long long n = 0;
    if (!parse_number(tok[0], n) || n < 0 || std::size_t(n) + 1 > tok.size())
      throw InputError(path, where() + "bad face line");
    poly.clear();
    for (long long k = 1; k <= n; ++k) {
      long long i = 0;
      if (!parse_number(tok[std::size_t(k)], i) || i < 0 || i >= nv)
        throw InputError(path, where() + "bad vertex index '" + std::string(tok[std::size_t(k)]) + "'");
      poly.push_back(i);
    }
    add_fan(m, poly, path, where);
  }
  if (colors) *colors = has_colors ? std::move(cols) : std::vector<Rgb>{};
  return m;
}

}  // namespace isoloft::detail
