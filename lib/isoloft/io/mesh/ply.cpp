// PLY (http://paulbourke.net/dataformats/ply/): binary little-endian or ASCII out; ASCII and both binary byte orders in.
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

void write_ply_header(Out& o, std::size_t vertices, std::size_t triangles, bool colors, bool ascii,
                      const std::string& space) {
  o.text("ply\nformat ", ascii ? "ascii" : "binary_little_endian", " 1.0\ncomment written by isoloft\n");
  if (!space.empty()) o.text("comment SPACE=", space, '\n');
  o.text("element vertex ", vertices, "\nproperty float x\nproperty float y\nproperty float z\n");
  if (colors) o.text("property uchar red\nproperty uchar green\nproperty uchar blue\n");
  o.text("element face ", triangles, "\nproperty list uchar int vertex_indices\nend_header\n");
}

void write_ply(const std::string& /*path*/, Out& o, const MeshOut& mo) {
  const TriMesh& m = mo.mesh;
  const Scaled& v = mo.vertices;
  const std::vector<Rgb>* colors = mo.colors;
  const bool ascii = mo.ascii;
  write_ply_header(o, m.vertices.size(), m.triangles.size(), colors != nullptr, ascii, mo.space);
  for (std::size_t i = 0; i < m.vertices.size(); ++i) {
    const Vec3f p = v[i];
    if (ascii) {
      o.text(p.x(), ' ', p.y(), ' ', p.z());
      if (colors) {
        const Rgb c = (*colors)[i];
        o.text(' ', int(c.r), ' ', int(c.g), ' ', int(c.b));
      }
      o.text('\n');
    } else {
      o.bin(p.x(), p.y(), p.z());
      if (colors) {
        const Rgb c = (*colors)[i];
        o.bin(c.r, c.g, c.b);
      }
    }
  }
  for (const auto& t : m.triangles) {
    if (ascii) {
      o.text("3 ", t[0], ' ', t[1], ' ', t[2], '\n');
    } else {
      o.bin(std::uint8_t(3), t[0], t[1], t[2]);
    }
  }
}

namespace {

enum class PlyType { I8, U8, I16, U16, I32, U32, F32, F64 };

bool ply_type(std::string_view s, PlyType& t) {
  static const std::pair<std::string_view, PlyType> names[] = {
      {"char", PlyType::I8},   {"int8", PlyType::I8},     {"uchar", PlyType::U8},   {"uint8", PlyType::U8},
      {"short", PlyType::I16}, {"int16", PlyType::I16},   {"ushort", PlyType::U16}, {"uint16", PlyType::U16},
      {"int", PlyType::I32},   {"int32", PlyType::I32},   {"uint", PlyType::U32},   {"uint32", PlyType::U32},
      {"float", PlyType::F32}, {"float32", PlyType::F32}, {"double", PlyType::F64}, {"float64", PlyType::F64}};
  for (const auto& [n, v] : names)
    if (s == n) {
      t = v;
      return true;
    }
  return false;
}

bool ply_float_type(PlyType t) { return t == PlyType::F32 || t == PlyType::F64; }

struct PlyProp {
  std::string name;
  bool list = false;
  PlyType count_type = PlyType::U8;
  PlyType type = PlyType::F32;
};
struct PlyElement {
  std::string name;
  std::size_t count = 0;
  std::vector<PlyProp> props;
};

class PlyBody {
 public:
  PlyBody(const char* p, const char* end, bool ascii, bool big, const std::string& path)
      : p_(p), end_(end), ascii_(ascii), big_(big), path_(path) {}

  double read(PlyType t) {
    if (ascii_) {
      while (p_ < end_ && is_space(*p_)) ++p_;
      const char* b = p_;
      while (p_ < end_ && !is_space(*p_)) ++p_;
      if (b == p_) throw InputError(path_, "PLY data ends early (truncated file?)");
      const std::string_view token(b, std::size_t(p_ - b));
      double v = 0.0;
      bool ok = false;
      if (t == PlyType::F32) {
        float f = 0.0f;
        ok = parse_number(token, f);
        v = f;
      } else {
        ok = parse_number(token, v);
      }
      if (!ok) throw InputError(path_, "PLY data: bad number '" + std::string(token) + "'");
      return v;
    }
    switch (t) {
      case PlyType::I8:
        return get<std::int8_t>();
      case PlyType::U8:
        return get<std::uint8_t>();
      case PlyType::I16:
        return get<std::int16_t>();
      case PlyType::U16:
        return get<std::uint16_t>();
      case PlyType::I32:
        return get<std::int32_t>();
      case PlyType::U32:
        return get<std::uint32_t>();
      case PlyType::F32:
        return get<float>();
      case PlyType::F64:
        return get<double>();
    }
    return 0.0;
  }
  [[nodiscard]] std::size_t remaining() const { return std::size_t(end_ - p_); }

 private:
  template <class T>
  double get() {
    if (std::size_t(end_ - p_) < sizeof(T)) throw InputError(path_, "PLY data ends early (truncated file?)");
    unsigned char b[sizeof(T)];
    std::memcpy(b, p_, sizeof(T));
    p_ += sizeof(T);
    if (big_ != (std::endian::native == std::endian::big)) std::reverse(b, b + sizeof(T));
    T v;
    std::memcpy(&v, b, sizeof(T));
    return double(v);
  }
  const char* p_;
  const char* end_;
  bool ascii_, big_;
  const std::string& path_;
};

long long ply_count(double v, const std::string& path) {
  if (!(v >= 0.0) || v != std::floor(v) || v > 1e9) throw InputError(path, "PLY data: bad list length");
  return (long long)v;
}

}  // namespace

TriMesh read_ply(const std::string& path, const std::vector<unsigned char>& bytes, std::vector<Rgb>* colors) {
  Lines lines(bytes.data(), bytes.data() + bytes.size());
  std::string_view line;
  std::vector<std::string_view> tok;
  if (!lines.next(line) || (split_tokens(line, tok, false), tok.size() != 1 || tok[0] != "ply"))
    throw InputError(path, "not a PLY file (first line is not 'ply')");
  bool ascii = false, big = false, have_format = false, ended = false;
  std::vector<PlyElement> elements;
  while (lines.next(line)) {
    split_tokens(line, tok, false);
    auto where = [&] { return at_line(lines.number()); };  // built only on error
    if (tok.empty()) continue;
    if (tok[0] == "end_header") {
      ended = true;
      break;
    }
    if (tok[0] == "comment" || tok[0] == "obj_info") continue;
    if (tok[0] == "format") {
      if (tok.size() != 3) throw InputError(path, where() + "bad format line");
      if (tok[1] == "ascii") {
        ascii = true;
      } else if (tok[1] == "binary_little_endian") {
        big = false;
      } else if (tok[1] == "binary_big_endian") {
        big = true;
      } else {
        throw InputError(path, where() + "unknown PLY format '" + std::string(tok[1]) + "'");
      }
      have_format = true;
    } else if (tok[0] == "element") {
      long long n = 0;
      if (tok.size() != 3 || !parse_number(tok[2], n) || n < 0) throw InputError(path, where() + "bad element line");
      elements.push_back({std::string(tok[1]), std::size_t(n), {}});
    } else if (tok[0] == "property") {
      if (elements.empty()) throw InputError(path, where() + "property before any element");
      PlyProp p;
      if (tok.size() == 5 && tok[1] == "list") {
        p.list = true;
        if (!ply_type(tok[2], p.count_type) || !ply_type(tok[3], p.type) || ply_float_type(p.count_type))
          throw InputError(path, where() + "bad list property types");
        p.name = std::string(tok[4]);
      } else if (tok.size() == 3) {
        if (!ply_type(tok[1], p.type)) throw InputError(path, where() + "unknown type '" + std::string(tok[1]) + "'");
        p.name = std::string(tok[2]);
      } else {
        throw InputError(path, where() + "bad property line");
      }
      elements.back().props.push_back(p);
    } else {
      throw InputError(path, where() + "unknown header keyword '" + std::string(tok[0]) + "'");
    }
  }
  if (!ended) throw InputError(path, "PLY header has no end_header");
  if (!have_format) throw InputError(path, "PLY header has no format line");

  PlyBody body(lines.position(), reinterpret_cast<const char*>(bytes.data() + bytes.size()), ascii, big, path);
  TriMesh m;
  std::vector<Rgb> cols;
  bool have_vertices = false, have_colors = false;
  std::vector<long long> poly;
  for (const PlyElement& e : elements) {
    // Every element takes at least one byte (binary) or two (ASCII): cap
    // reservations so a corrupt count cannot allocate gigabytes.
    const std::size_t cap = std::min(e.count, body.remaining());
    if (e.name == "vertex") {
      int ix = -1, iy = -1, iz = -1, ir = -1, ig = -1, ib = -1;
      for (std::size_t k = 0; k < e.props.size(); ++k) {
        const auto& n = e.props[k].name;
        if (e.props[k].list) continue;
        if (n == "x") ix = int(k);
        if (n == "y") iy = int(k);
        if (n == "z") iz = int(k);
        if (n == "red" || n == "r" || n == "diffuse_red") ir = int(k);
        if (n == "green" || n == "g" || n == "diffuse_green") ig = int(k);
        if (n == "blue" || n == "b" || n == "diffuse_blue") ib = int(k);
      }
      if (ix < 0 || iy < 0 || iz < 0) throw InputError(path, "PLY vertex element lacks x, y or z");
      have_vertices = true;
      have_colors = ir >= 0 && ig >= 0 && ib >= 0;
      m.vertices.reserve(cap);
      if (have_colors) cols.reserve(cap);
      std::vector<double> vals(e.props.size());
      for (std::size_t i = 0; i < e.count; ++i) {
        for (std::size_t k = 0; k < e.props.size(); ++k) {
          const PlyProp& p = e.props[k];
          if (p.list) {
            const long long n = ply_count(body.read(p.count_type), path);
            for (long long j = 0; j < n; ++j) body.read(p.type);
          } else {
            vals[k] = body.read(p.type);
          }
        }
        m.vertices.emplace_back(float(vals[std::size_t(ix)]), float(vals[std::size_t(iy)]),
                                float(vals[std::size_t(iz)]));
        if (have_colors) {
          auto comp = [&](int k) {
            return color_component(vals[std::size_t(k)], ply_float_type(e.props[std::size_t(k)].type));
          };
          cols.push_back({comp(ir), comp(ig), comp(ib)});
        }
      }
    } else if (e.name == "face") {
      int iv = -1;
      for (std::size_t k = 0; k < e.props.size(); ++k)
        if (e.props[k].list && (e.props[k].name == "vertex_indices" || e.props[k].name == "vertex_index")) iv = int(k);
      if (iv < 0) throw InputError(path, "PLY face element lacks a vertex_indices list");
      m.triangles.reserve(cap);
      for (std::size_t i = 0; i < e.count; ++i) {
        for (std::size_t k = 0; k < e.props.size(); ++k) {
          const PlyProp& p = e.props[k];
          if (!p.list) {
            body.read(p.type);
            continue;
          }
          const long long n = ply_count(body.read(p.count_type), path);
          if (int(k) != iv) {
            for (long long j = 0; j < n; ++j) body.read(p.type);
            continue;
          }
          poly.clear();
          for (long long j = 0; j < n; ++j) {
            const double v = body.read(p.type);
            if (v != std::floor(v) || v < 0 || v > double(std::numeric_limits<std::int32_t>::max()))
              throw InputError(path, "PLY face " + std::to_string(i) + ": bad vertex index");
            poly.push_back((long long)v);
          }
          add_fan(m, poly, path, [&] { return "PLY face " + std::to_string(i) + ": "; });
        }
      }
    } else {
      for (std::size_t i = 0; i < e.count; ++i)
        for (const PlyProp& p : e.props) {
          const long long n = p.list ? ply_count(body.read(p.count_type), path) : 1;
          for (long long j = 0; j < n; ++j) body.read(p.type);
        }
    }
  }
  if (!have_vertices) throw InputError(path, "PLY file has no vertex element");
  check_indices(m, path);
  if (colors) *colors = have_colors ? std::move(cols) : std::vector<Rgb>{};
  return m;
}

}  // namespace isoloft::detail
