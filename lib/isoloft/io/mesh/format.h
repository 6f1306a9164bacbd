// @file io/mesh/format.h
// @brief Internals of the mesh readers and writers (io/mesh_io.h): one
// reader/writer pair per format file, the shared buffered output and checks.
#pragma once

#include <algorithm>
#include <bit>
#include <charconv>
#include <cstdint>
#include <cstring>
#include <type_traits>
#include <cstdio>
#include <string>
#include <string_view>
#include <vector>

#include "isoloft/core/error.h"
#include "isoloft/core/mesh.h"
#include "isoloft/io/mesh_io.h"

namespace isoloft::detail {

/// Buffered text / little-endian binary output to a FILE*.
class Out {
 public:
  Out(std::string path, const std::string& file);
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
    (put_bin<std::endian::little>(v), ...);
  }
  /// Binary big-endian (legacy VTK).
  template <class... T>
  void bin_be(T... v) {
    (put_bin<std::endian::big>(v), ...);
  }
  /// Flush and close. \throw Error on any write error (e.g. disk full).
  void close();

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
  template <std::endian order, class T>
  void put_bin(T v) {
    unsigned char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    if constexpr (std::endian::native != order) std::reverse(b, b + sizeof(T));
    buf_.append(reinterpret_cast<const char*>(b), sizeof(T));
    if (buf_.size() >= capacity) flush();
  }
  void flush();
  static constexpr std::size_t capacity = std::size_t(1) << 20;
  std::string path_;
  std::FILE* fp_ = nullptr;
  std::string buf_;
};

/// The mesh's vertices as written: multiplied by a scale (pixel units ->
/// physical units), or, with a frame, placed in patient space on the fly
/// (patient_point(), the arithmetic of in_patient_space(): the same floats
/// without a copy of the mesh).
struct Scaled {
  const TriMesh& m;
  double s;
  const PatientFrame* frame = nullptr;  ///< non-null: patient_point(*frame, ras, vertex); s is ignored
  bool ras = false;
  [[nodiscard]] Vec3f operator[](std::size_t i) const {
    if (frame) return patient_point(*frame, ras, m.vertices[i]);
    return s == 1.0 ? m.vertices[i] : Vec3f((m.vertices[i].cast<double>() * s).cast<float>());
  }
};

/// What a writer is given.
struct MeshOut {
  const TriMesh& mesh;
  Scaled vertices;
  const std::vector<Rgb>* colors;  ///< one per vertex, or null
  bool ascii;
  /// Patient space of the coordinates ("LPS", "RAS"), written into the header
  /// as 3D Slicer reads it ("SPACE=LPS"); empty: none.
  std::string space;
  /// Per-triangle labels (cell data of the VTK formats), or null: every triangle `label`.
  const std::vector<std::uint32_t>* labels = nullptr;
  std::uint32_t label = 0;
  /// The labels' names (VTK field data "label" and "label_name"), or null / empty: none.
  const std::vector<LabelName>* label_names = nullptr;
};

/// Triangle t's label (MeshOut::labels, else MeshOut::label).
inline std::uint32_t cell_label(const MeshOut& m, std::size_t t) { return m.labels ? (*m.labels)[t] : m.label; }

/// Unit normal of triangle (a, b, c), counter-clockwise; zero if degenerate.
Vec3f facet_normal(const Vec3f& a, const Vec3f& b, const Vec3f& c);

void write_ply(const std::string& path, Out& o, const MeshOut& m);
/// The PLY header write_ply() writes (PlyPartWriter shares it).
void write_ply_header(Out& o, std::size_t vertices, std::size_t triangles, bool colors, bool ascii,
                      const std::string& space);
void write_obj(const std::string& path, Out& o, const MeshOut& m);
void write_stl(const std::string& path, Out& o, const MeshOut& m);
void write_off(const std::string& path, Out& o, const MeshOut& m);
void write_vtk(const std::string& path, Out& o, const MeshOut& m);
void write_vtp(const std::string& path, Out& o, const MeshOut& m);

/// Readers of the whole file's bytes; colours cleared when the file has none.
TriMesh read_ply(const std::string& path, const std::vector<unsigned char>& bytes, std::vector<Rgb>* colors);
TriMesh read_obj(const std::string& path, const std::vector<unsigned char>& bytes, std::vector<Rgb>* colors);
TriMesh read_stl(const std::string& path, const std::vector<unsigned char>& bytes, std::vector<Rgb>* colors);
TriMesh read_off(const std::string& path, const std::vector<unsigned char>& bytes, std::vector<Rgb>* colors);

/// "line N: " for messages.
std::string at_line(std::size_t n);
/// Appends polygon `poly` as a triangle fan. \throw InputError naming `path`
/// and where() (called only then) for fewer than 3 vertices.
template <class Where>
void add_fan(TriMesh& m, const std::vector<long long>& poly, const std::string& path, const Where& where) {
  if (poly.size() < 3)
    throw InputError(path, where() + "face with " + std::to_string(poly.size()) + " vertices (need at least 3)");
  for (std::size_t i = 1; i + 1 < poly.size(); ++i)
    m.triangles.push_back({std::int32_t(poly[0]), std::int32_t(poly[i]), std::int32_t(poly[i + 1])});
}
/// \throw InputError naming the triangle if an index is out of range.
void check_indices(const TriMesh& m, const std::string& path);
/// A colour component from 0..1 (unit_range) or 0..255.
std::uint8_t color_component(double v, bool unit_range);

}  // namespace isoloft::detail
