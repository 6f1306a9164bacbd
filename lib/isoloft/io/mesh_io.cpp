#include "isoloft/io/mesh_io.h"

#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <string_view>
#include <type_traits>
#include <unordered_map>

#include "isoloft/core/error.h"
#include "isoloft/io/atomic_file.h"
#include "isoloft/io/volume.h"

namespace isoloft {
namespace {

std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}

// ---------------------------------------------------------------- writing

/// Buffered text / little-endian binary output to a FILE*.
class Out {
 public:
  Out(std::string path, const std::string& file) : path_(std::move(path)) {
    fp_ = std::fopen(file.c_str(), "wb");
    if (!fp_) throw Error(path_ + ": cannot create file (" + std::strerror(errno) + ")");
    buf_.reserve(capacity);
  }
  ~Out() {
    if (fp_) std::fclose(fp_);
  }
  Out(const Out&) = delete;
  Out& operator=(const Out&) = delete;

  /// Text: chars and strings as they are; numbers in the shortest form that
  /// parses back to the same value (std::to_chars).
  template <class... A>
  void text(const A&... a) {
    (put_text(a), ...);
  }
  /// Binary little-endian, each value at its own width.
  template <class... T>
  void bin(T... v) {
    (put_bin(v), ...);
  }
  /// Flush and close. \throw Error on any write error (e.g. disk full).
  void close() {
    flush();
    const bool bad = std::ferror(fp_) != 0;
    const bool close_bad = std::fclose(fp_) != 0;
    fp_ = nullptr;
    if (bad || close_bad) throw Error(path_ + ": write error (" + std::strerror(errno) + ")");
  }

 private:
  template <class T>
  void put_text(const T& v) {
    if constexpr (std::is_same_v<T, char>) {
      buf_.push_back(v);
    } else if constexpr (std::is_arithmetic_v<T>) {
      char tmp[64];
      const auto r = std::to_chars(tmp, tmp + sizeof tmp, v);
      buf_.append(tmp, r.ptr);
    } else {
      buf_.append(std::string_view(v));
    }
    if (buf_.size() >= capacity) flush();
  }
  template <class T>
  void put_bin(T v) {
    unsigned char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    if constexpr (std::endian::native == std::endian::big) std::reverse(b, b + sizeof(T));
    buf_.append(reinterpret_cast<const char*>(b), sizeof(T));
    if (buf_.size() >= capacity) flush();
  }
  void flush() {
    if (!buf_.empty() && std::fwrite(buf_.data(), 1, buf_.size(), fp_) != buf_.size())
      throw Error(path_ + ": write error (" + std::strerror(errno) + ")");
    buf_.clear();
  }
  static constexpr std::size_t capacity = std::size_t(1) << 20;
  std::string path_;
  std::FILE* fp_ = nullptr;
  std::string buf_;
};

struct Scaled {
  const TriMesh& m;
  double s;
  [[nodiscard]] Vec3f operator[](std::size_t i) const {
    return s == 1.0 ? m.vertices[i] : Vec3f((m.vertices[i].cast<double>() * s).cast<float>());
  }
};

void write_ply(Out& o, const TriMesh& m, const Scaled& v, const std::vector<Rgb>* colors, bool ascii) {
  o.text("ply\nformat ", ascii ? "ascii" : "binary_little_endian", " 1.0\ncomment written by isoloft\n");
  o.text("element vertex ", m.vertices.size(), "\nproperty float x\nproperty float y\nproperty float z\n");
  if (colors) o.text("property uchar red\nproperty uchar green\nproperty uchar blue\n");
  o.text("element face ", m.triangles.size(), "\nproperty list uchar int vertex_indices\nend_header\n");
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

void write_obj(Out& o, const TriMesh& m, const Scaled& v, const std::vector<Rgb>* colors) {
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

Vec3f facet_normal(const Vec3f& a, const Vec3f& b, const Vec3f& c) {
  const Vec3d u = (b - a).cast<double>(), w = (c - a).cast<double>();
  const Vec3d n(u.y() * w.z() - u.z() * w.y(), u.z() * w.x() - u.x() * w.z(), u.x() * w.y() - u.y() * w.x());
  const double len = n.norm();
  return len > 0.0 ? Vec3f((n / len).cast<float>()) : Vec3f::Zero();
}

void write_stl(const std::string& path, Out& o, const TriMesh& m, const Scaled& v, bool ascii) {
  if (ascii) {
    o.text("solid isoloft\n");
    for (const auto& t : m.triangles) {
      const Vec3f a = v[std::size_t(t[0])], b = v[std::size_t(t[1])], c = v[std::size_t(t[2])];
      const Vec3f n = facet_normal(a, b, c);
      o.text("facet normal ", n.x(), ' ', n.y(), ' ', n.z());
      o.text("\n outer loop\n");
      for (const Vec3f* p : {&a, &b, &c}) {
        o.text("  vertex ", p->x(), ' ', p->y(), ' ', p->z(), '\n');
      }
      o.text(" endloop\nendfacet\n");
    }
    o.text("endsolid isoloft\n");
    return;
  }
  if (m.triangles.size() > std::numeric_limits<std::uint32_t>::max())
    throw Error(path + ": too many triangles for binary STL");
  // The 80-byte header must not start with "solid", or readers take it for ASCII.
  char header[80];
  std::memset(header, ' ', sizeof header);
  const char* text = "binary STL written by isoloft";
  std::memcpy(header, text, std::strlen(text));
  o.text(std::string_view(header, sizeof header));
  o.bin(std::uint32_t(m.triangles.size()));
  for (const auto& t : m.triangles) {
    const Vec3f a = v[std::size_t(t[0])], b = v[std::size_t(t[1])], c = v[std::size_t(t[2])];
    const Vec3f n = facet_normal(a, b, c);
    for (const Vec3f* p : {&n, &a, &b, &c}) o.bin(p->x(), p->y(), p->z());
    o.bin(std::uint16_t(0));
  }
}

void write_off(Out& o, const TriMesh& m, const Scaled& v, const std::vector<Rgb>* colors) {
  o.text(colors ? "COFF\n" : "OFF\n");
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

// ---------------------------------------------------------------- reading

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f'; }

bool parse_double(std::string_view s, double& out) {
  if (!s.empty() && s[0] == '+') s.remove_prefix(1);
  const auto r = std::from_chars(s.data(), s.data() + s.size(), out);
  return r.ec == std::errc() && r.ptr == s.data() + s.size();
}

// Coordinates are parsed straight to float (not via double) so that the
// shortest float text written by the writers reads back bit-exactly.
bool parse_float(std::string_view s, float& out) {
  if (!s.empty() && s[0] == '+') s.remove_prefix(1);
  const auto r = std::from_chars(s.data(), s.data() + s.size(), out);
  return r.ec == std::errc() && r.ptr == s.data() + s.size();
}

bool parse_int(std::string_view s, long long& out) {
  if (!s.empty() && s[0] == '+') s.remove_prefix(1);
  const auto r = std::from_chars(s.data(), s.data() + s.size(), out);
  return r.ec == std::errc() && r.ptr == s.data() + s.size();
}

/// Line-by-line view of a text buffer with 1-based line numbers.
class Lines {
 public:
  Lines(const unsigned char* begin, const unsigned char* end)
      : p_(reinterpret_cast<const char*>(begin)), end_(reinterpret_cast<const char*>(end)) {}
  bool next(std::string_view& line) {
    if (p_ >= end_) return false;
    const char* e = static_cast<const char*>(std::memchr(p_, '\n', std::size_t(end_ - p_)));
    if (!e) e = end_;
    line = std::string_view(p_, std::size_t(e - p_));
    p_ = e < end_ ? e + 1 : end_;
    ++number_;
    return true;
  }
  [[nodiscard]] std::size_t number() const { return number_; }
  [[nodiscard]] const char* position() const { return p_; }

 private:
  const char* p_;
  const char* end_;
  std::size_t number_ = 0;
};

/// Whitespace-separated tokens of a line, after cutting a '#' comment if asked.
void split(std::string_view line, std::vector<std::string_view>& tokens, bool hash_comments) {
  tokens.clear();
  if (hash_comments) {
    const std::size_t h = line.find('#');
    if (h != std::string_view::npos) line = line.substr(0, h);
  }
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_space(line[i])) ++i;
    const std::size_t b = i;
    while (i < line.size() && !is_space(line[i])) ++i;
    if (i > b) tokens.push_back(line.substr(b, i - b));
  }
}

std::string at_line(std::size_t n) { return "line " + std::to_string(n) + ": "; }

/// Append polygon `poly` as a triangle fan; checks the vertex count.
template <class Where>
void add_fan(TriMesh& m, const std::vector<long long>& poly, const std::string& path, const Where& where) {
  if (poly.size() < 3)
    throw InputError(path, where() + "face with " + std::to_string(poly.size()) + " vertices (need at least 3)");
  for (std::size_t i = 1; i + 1 < poly.size(); ++i)
    m.triangles.push_back({std::int32_t(poly[0]), std::int32_t(poly[i]), std::int32_t(poly[i + 1])});
}

void check_indices(const TriMesh& m, const std::string& path) {
  const auto n = std::int64_t(m.vertices.size());
  for (std::size_t t = 0; t < m.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k)
      if (m.triangles[t][k] < 0 || m.triangles[t][k] >= n)
        throw InputError(path, "triangle " + std::to_string(t) + " references vertex " +
                                   std::to_string(m.triangles[t][k]) + " but there are " + std::to_string(n) +
                                   " vertices");
}

std::uint8_t color_component(double v, bool unit_range) {
  const double c = unit_range ? v * 255.0 : v;
  return std::uint8_t(std::clamp(std::lround(c), 0L, 255L));
}

// ---- PLY

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
        ok = parse_float(token, f);
        v = f;
      } else {
        ok = parse_double(token, v);
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

TriMesh read_ply(const std::string& path, const std::vector<unsigned char>& bytes, std::vector<Rgb>* colors) {
  Lines lines(bytes.data(), bytes.data() + bytes.size());
  std::string_view line;
  std::vector<std::string_view> tok;
  if (!lines.next(line) || (split(line, tok, false), tok.size() != 1 || tok[0] != "ply"))
    throw InputError(path, "not a PLY file (first line is not 'ply')");
  bool ascii = false, big = false, have_format = false, ended = false;
  std::vector<PlyElement> elements;
  while (lines.next(line)) {
    split(line, tok, false);
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
      if (tok.size() != 3 || !parse_int(tok[2], n) || n < 0) throw InputError(path, where() + "bad element line");
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

// ---- OBJ

TriMesh read_obj(const std::string& path, const std::vector<unsigned char>& bytes, std::vector<Rgb>* colors) {
  Lines lines(bytes.data(), bytes.data() + bytes.size());
  std::string_view line;
  std::vector<std::string_view> tok;
  TriMesh m;
  std::vector<Rgb> cols;
  bool all_colored = true;
  std::vector<long long> poly;
  while (lines.next(line)) {
    split(line, tok, true);
    if (tok.empty()) continue;
    auto where = [&] { return at_line(lines.number()); };  // built only on error
    if (tok[0] == "v") {
      float c[6];
      const std::size_t n = tok.size() - 1;
      if (n < 3 || n > 7) throw InputError(path, where() + "expected 3 coordinates after 'v'");
      for (std::size_t k = 0; k < std::min<std::size_t>(n, 6); ++k)
        if (!parse_float(tok[k + 1], c[k]))
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
        if (!parse_int(idx, i) || i == 0)
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

// ---- STL

std::uint32_t bswap32(std::uint32_t v) { return (v >> 24) | ((v >> 8) & 0xFF00u) | ((v << 8) & 0xFF0000u) | (v << 24); }

struct PositionHash {
  std::size_t operator()(const std::array<std::uint32_t, 3>& k) const {
    std::uint64_t h = 1469598103934665603ull;
    for (std::uint32_t v : k) h = (h ^ v) * 1099511628211ull;
    return std::size_t(h ^ (h >> 29));
  }
};

/// Welds STL corners by exact float position (-0 and +0 are the same point).
class Welder {
 public:
  explicit Welder(TriMesh& m) : m_(m) {}
  void reserve(std::size_t n) {
    index_.reserve(n);
    m_.vertices.reserve(n);
  }
  std::int32_t add(float x, float y, float z) {
    x += 0.0f, y += 0.0f, z += 0.0f;  // -0 -> +0
    const std::array<std::uint32_t, 3> key{std::bit_cast<std::uint32_t>(x), std::bit_cast<std::uint32_t>(y),
                                           std::bit_cast<std::uint32_t>(z)};
    const auto [it, inserted] = index_.try_emplace(key, std::int32_t(m_.vertices.size()));
    if (inserted) m_.vertices.emplace_back(x, y, z);
    return it->second;
  }

 private:
  TriMesh& m_;
  std::unordered_map<std::array<std::uint32_t, 3>, std::int32_t, PositionHash> index_;
};

TriMesh read_stl(const std::string& path, const std::vector<unsigned char>& bytes) {
  TriMesh m;
  Welder weld(m);
  const std::size_t size = bytes.size();
  std::uint32_t count = 0;
  if (size >= 84) std::memcpy(&count, bytes.data() + 80, 4);
  if constexpr (std::endian::native == std::endian::big) count = bswap32(count);
  const bool binary = size >= 84 && 84 + 50 * std::uint64_t(count) == size;
  const bool starts_solid = size >= 5 && std::memcmp(bytes.data(), "solid", 5) == 0;
  if (binary) {
    m.triangles.reserve(count);
    weld.reserve(count / 2 + 3);  // a closed mesh has about half as many vertices as triangles
    for (std::uint32_t t = 0; t < count; ++t) {
      const unsigned char* rec = bytes.data() + 84 + 50 * std::size_t(t) + 12;  // skip the normal
      std::array<std::int32_t, 3> tri{};
      for (int k = 0; k < 3; ++k) {
        float c[3];
        std::memcpy(c, rec + 12 * k, 12);
        if constexpr (std::endian::native == std::endian::big)
          for (float& f : c) f = std::bit_cast<float>(bswap32(std::bit_cast<std::uint32_t>(f)));
        tri[std::size_t(k)] = weld.add(c[0], c[1], c[2]);
      }
      m.triangles.push_back(tri);
    }
    return m;
  }
  if (!starts_solid) {
    if (size >= 84)
      throw InputError(path, "binary STL size " + std::to_string(size) + " bytes does not match its " +
                                 std::to_string(count) + " triangles (truncated?)");
    throw InputError(path, "not an STL file");
  }
  Lines lines(bytes.data(), bytes.data() + size);
  std::string_view line;
  std::vector<std::string_view> tok;
  std::vector<long long> loop;
  bool in_loop = false, ended = false;
  while (lines.next(line)) {
    split(line, tok, false);
    if (tok.empty()) continue;
    auto where = [&] { return at_line(lines.number()); };  // built only on error
    if (tok[0] == "outer") {
      if (in_loop) throw InputError(path, where() + "nested 'outer loop'");
      in_loop = true;
      loop.clear();
    } else if (tok[0] == "vertex") {
      float c[3];
      if (!in_loop || tok.size() != 4 || !parse_float(tok[1], c[0]) || !parse_float(tok[2], c[1]) ||
          !parse_float(tok[3], c[2]))
        throw InputError(path, where() + "bad vertex line");
      loop.push_back(weld.add(c[0], c[1], c[2]));
    } else if (tok[0] == "endloop") {
      if (!in_loop) throw InputError(path, where() + "'endloop' without 'outer loop'");
      in_loop = false;
      add_fan(m, loop, path, where);
    } else if (tok[0] == "endsolid") {
      ended = true;
    }
    // solid, facet normal, endfacet: nothing to keep
  }
  if (in_loop || !ended) throw InputError(path, "ASCII STL ends early (truncated file?)");
  return m;
}

// ---- OFF

TriMesh read_off(const std::string& path, const std::vector<unsigned char>& bytes, std::vector<Rgb>* colors) {
  Lines lines(bytes.data(), bytes.data() + bytes.size());
  std::string_view line;
  std::vector<std::string_view> tok;
  auto next_tokens = [&]() {
    while (lines.next(line)) {
      split(line, tok, true);
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
  if (counts.size() < 2 || !parse_int(counts[0], nv) || !parse_int(counts[1], nf) || nv < 0 || nf < 0)
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
      if (!parse_float(tok[std::size_t(k)], c[k]))
        throw InputError(path, where() + "bad number '" + std::string(tok[std::size_t(k)]) + "'");
    m.vertices.emplace_back(c[0], c[1], c[2]);
    if (has_colors) {
      if (tok.size() < need + 3) throw InputError(path, where() + "COFF vertex lacks a colour");
      double rgb[3];
      bool unit = false;
      for (int k = 0; k < 3; ++k) {
        const std::string_view t = tok[need + std::size_t(k)];
        if (!parse_double(t, rgb[k])) throw InputError(path, where() + "bad colour '" + std::string(t) + "'");
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
    if (!parse_int(tok[0], n) || n < 0 || std::size_t(n) + 1 > tok.size())
      throw InputError(path, where() + "bad face line");
    poly.clear();
    for (long long k = 1; k <= n; ++k) {
      long long i = 0;
      if (!parse_int(tok[std::size_t(k)], i) || i < 0 || i >= nv)
        throw InputError(path, where() + "bad vertex index '" + std::string(tok[std::size_t(k)]) + "'");
      poly.push_back(i);
    }
    add_fan(m, poly, path, where);
  }
  if (colors) *colors = has_colors ? std::move(cols) : std::vector<Rgb>{};
  return m;
}

}  // namespace

MeshFormat mesh_format_from_path(const std::string& path) {
  const std::string ext = lower_extension(path);
  if (ext == ".ply") return MeshFormat::Ply;
  if (ext == ".obj") return MeshFormat::Obj;
  if (ext == ".stl") return MeshFormat::Stl;
  if (ext == ".off") return MeshFormat::Off;
  throw ParamError(path + ": unknown mesh format '" + ext + "' (use .ply, .obj, .stl or .off)");
}

void write_mesh(const std::string& path, const TriMesh& m, double scale, const std::vector<Rgb>* vertex_colors,
                bool ascii) {
  const MeshFormat format = mesh_format_from_path(path);
  if (!(std::isfinite(scale) && scale > 0.0))
    throw ParamError(path + ": mesh scale must be finite and > 0, got " + std::to_string(scale));
  if (vertex_colors && vertex_colors->size() != m.vertices.size())
    throw ParamError(path + ": " + std::to_string(vertex_colors->size()) + " vertex colours for " +
                     std::to_string(m.vertices.size()) + " vertices");
  if (m.vertices.size() > std::size_t(std::numeric_limits<std::int32_t>::max()))
    throw Error(path + ": too many vertices");
  const auto n = std::int64_t(m.vertices.size());
  for (std::size_t t = 0; t < m.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k)
      if (m.triangles[t][k] < 0 || m.triangles[t][k] >= n)
        throw Error(path + ": triangle " + std::to_string(t) + " references vertex " +
                    std::to_string(m.triangles[t][k]) + " of " + std::to_string(n));
  AtomicFile file(path);
  {
    Out o(path, file.temp_path());
    const Scaled v{m, scale};
    switch (format) {
      case MeshFormat::Ply:
        write_ply(o, m, v, vertex_colors, ascii);
        break;
      case MeshFormat::Obj:
        write_obj(o, m, v, vertex_colors);
        break;
      case MeshFormat::Stl:
        write_stl(path, o, m, v, ascii);
        break;
      case MeshFormat::Off:
        write_off(o, m, v, vertex_colors);
        break;
    }
    o.close();
  }
  file.commit();
}

TriMesh read_mesh(const std::string& path, std::vector<Rgb>* vertex_colors) {
  const std::string ext = lower_extension(path);
  MeshFormat format;
  if (ext == ".ply") {
    format = MeshFormat::Ply;
  } else if (ext == ".obj") {
    format = MeshFormat::Obj;
  } else if (ext == ".stl") {
    format = MeshFormat::Stl;
  } else if (ext == ".off") {
    format = MeshFormat::Off;
  } else {
    throw InputError(path, "unknown mesh format '" + ext + "' (use .ply, .obj, .stl or .off)");
  }
  const std::vector<unsigned char> bytes = detail::read_file_bytes(path);
  switch (format) {
    case MeshFormat::Ply:
      return read_ply(path, bytes, vertex_colors);
    case MeshFormat::Obj:
      return read_obj(path, bytes, vertex_colors);
    case MeshFormat::Stl:
      if (vertex_colors) vertex_colors->clear();
      return read_stl(path, bytes);
    case MeshFormat::Off:
      return read_off(path, bytes, vertex_colors);
  }
  return {};
}

TriMesh merge_meshes(const std::vector<TriMesh>& parts, const std::vector<Rgb>& part_colors,
                     std::vector<Rgb>* vertex_colors) {
  if (!part_colors.empty() && part_colors.size() != parts.size())
    throw ParamError("merge_meshes: " + std::to_string(part_colors.size()) + " colours for " +
                     std::to_string(parts.size()) + " meshes");
  TriMesh out;
  std::size_t nv = 0, nt = 0;
  for (const auto& p : parts) nv += p.vertices.size(), nt += p.triangles.size();
  out.vertices.reserve(nv);
  out.triangles.reserve(nt);
  if (vertex_colors) {
    vertex_colors->clear();
    if (!part_colors.empty()) vertex_colors->reserve(nv);
  }
  for (std::size_t i = 0; i < parts.size(); ++i) {
    const auto offset = std::int32_t(out.vertices.size());
    out.vertices.insert(out.vertices.end(), parts[i].vertices.begin(), parts[i].vertices.end());
    for (const auto& t : parts[i].triangles) out.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
    if (vertex_colors && !part_colors.empty())
      vertex_colors->insert(vertex_colors->end(), parts[i].vertices.size(), part_colors[i]);
  }
  return out;
}

}  // namespace isoloft
