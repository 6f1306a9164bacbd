// STL (3D Systems): binary or ASCII, facet normals written, vertices welded by exact position on reading.
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


void write_stl(const std::string& path, Out& o, const MeshOut& mo) {
  const TriMesh& m = mo.mesh;
  const Scaled& v = mo.vertices;
  const bool ascii = mo.ascii;
  if (ascii) {
    o.text("solid isoloft", mo.space.empty() ? "" : " SPACE=", mo.space, '\n');
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
  const std::string text = "binary STL written by isoloft" + (mo.space.empty() ? std::string() : " SPACE=" + mo.space);
  std::memcpy(header, text.data(), text.size());
  o.text(std::string_view(header, sizeof header));
  o.bin(std::uint32_t(m.triangles.size()));
  for (const auto& t : m.triangles) {
    const Vec3f a = v[std::size_t(t[0])], b = v[std::size_t(t[1])], c = v[std::size_t(t[2])];
    const Vec3f n = facet_normal(a, b, c);
    for (const Vec3f* p : {&n, &a, &b, &c}) o.bin(p->x(), p->y(), p->z());
    o.bin(std::uint16_t(0));
  }
}

namespace {

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

}  // namespace

TriMesh read_stl(const std::string& path, const std::vector<unsigned char>& bytes, std::vector<Rgb>* colors) {
  if (colors) colors->clear();  // STL has no colours
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
    split_tokens(line, tok, false);
    if (tok.empty()) continue;
    auto where = [&] { return at_line(lines.number()); };  // built only on error
    if (tok[0] == "outer") {
      if (in_loop) throw InputError(path, where() + "nested 'outer loop'");
      in_loop = true;
      loop.clear();
    } else if (tok[0] == "vertex") {
      float c[3];
      if (!in_loop || tok.size() != 4 || !parse_number(tok[1], c[0]) || !parse_number(tok[2], c[1]) ||
          !parse_number(tok[3], c[2]))
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

}  // namespace isoloft::detail
