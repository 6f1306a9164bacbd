#include "isoloft/io/mesh_io.h"

#include <Eigen/Dense>
#include <fcntl.h>
#include <unistd.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>

#include "isoloft/core/error.h"
#include "isoloft/io/atomic_file.h"
#include "isoloft/io/file_util.h"
#include "isoloft/io/mesh/format.h"

namespace isoloft {

namespace {

using ReadFn = TriMesh (*)(const std::string&, const std::vector<unsigned char>&, std::vector<Rgb>*);
using WriteFn = void (*)(const std::string&, detail::Out&, const detail::MeshOut&);

struct FormatEntry {
  MeshFormatInfo info;
  ReadFn read;
  WriteFn write;
};

// What each format supports, and its reader and writer (io/mesh/*.cpp).
const std::array<FormatEntry, 6> kFormats{{
    {{MeshFormat::Ply, ".ply", "PLY", true, true, true}, detail::read_ply, detail::write_ply},
    {{MeshFormat::Obj, ".obj", "Wavefront OBJ", true, false, true}, detail::read_obj, detail::write_obj},
    {{MeshFormat::Stl, ".stl", "STL", false, true, true}, detail::read_stl, detail::write_stl},
    {{MeshFormat::Off, ".off", "OFF/COFF", true, false, true}, detail::read_off, detail::write_off},
    {{MeshFormat::Vtp, ".vtp", "VTK XML PolyData", true, true, false}, nullptr, detail::write_vtp},
    {{MeshFormat::Vtk, ".vtk", "legacy VTK PolyData", true, true, false}, nullptr, detail::write_vtk},
}};

std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}

const FormatEntry* entry_for(const std::string& path) {
  const std::string ext = lower_extension(path);
  for (const auto& f : kFormats)
    if (ext == f.info.extension) return &f;
  return nullptr;
}

std::string unknown_format(const std::string& path) {
  return "unknown mesh format '" + lower_extension(path) + "' (use .ply, .obj, .stl, .off, .vtp or .vtk)";
}

}  // namespace

namespace detail {

Out::Out(std::string path, const std::string& file) : path_(std::move(path)) {
  fp_ = std::fopen(file.c_str(), "wb");
  if (!fp_) throw Error(path_ + ": cannot create file (" + std::strerror(errno) + ")");
  buf_.reserve(capacity);
}

void Out::close() {
  flush();
  const bool bad = std::ferror(fp_) != 0;
  const bool close_bad = std::fclose(fp_) != 0;
  fp_ = nullptr;
  if (bad || close_bad) throw Error(path_ + ": write error (" + std::strerror(errno) + ")");
}

void Out::flush() {
  if (!buf_.empty() && std::fwrite(buf_.data(), 1, buf_.size(), fp_) != buf_.size())
    throw Error(path_ + ": write error (" + std::strerror(errno) + ")");
  buf_.clear();
}

Vec3f facet_normal(const Vec3f& a, const Vec3f& b, const Vec3f& c) {
  const Vec3d u = (b - a).cast<double>(), w = (c - a).cast<double>();
  const Vec3d n(u.y() * w.z() - u.z() * w.y(), u.z() * w.x() - u.x() * w.z(), u.x() * w.y() - u.y() * w.x());
  const double len = n.norm();
  return len > 0.0 ? Vec3f((n / len).cast<float>()) : Vec3f::Zero();
}

std::string at_line(std::size_t n) { return "line " + std::to_string(n) + ": "; }

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

}  // namespace detail

TriMesh in_patient_space(const TriMesh& m, const PatientFrame& frame, bool ras) {
  TriMesh out;
  out.vertices.resize(m.vertices.size());
  out.triangles.resize(m.triangles.size());
  const bool flip = frame.axes.determinant() < 0;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, m.vertices.size()), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t i = r.begin(); i < r.end(); ++i) out.vertices[i] = patient_point(frame, ras, m.vertices[i]);
  });
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, m.triangles.size()), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t i = r.begin(); i < r.end(); ++i) {
      out.triangles[i] = m.triangles[i];
      if (flip) std::swap(out.triangles[i][1], out.triangles[i][2]);
    }
  });
  return out;
}

namespace {
void write_mesh_as(const std::string& path, const TriMesh& m, const MeshWriteOptions& options, const std::string& space,
                   const PatientFrame* frame = nullptr);
}

std::vector<MeshFormatInfo> mesh_formats() {
  std::vector<MeshFormatInfo> out;
  for (const auto& f : kFormats) out.push_back(f.info);
  return out;
}

MeshFormat mesh_format_from_path(const std::string& path) {
  const FormatEntry* f = entry_for(path);
  if (!f) throw ParamError(path + ": " + unknown_format(path));
  return f->info.format;
}

void write_mesh(const std::string& path, const TriMesh& m, double scale, const std::vector<Rgb>* vertex_colors,
                bool ascii) {
  MeshWriteOptions o;
  o.scale = scale;
  o.colors = vertex_colors;
  o.ascii = ascii;
  write_mesh(path, m, o);
}

void write_mesh(const std::string& path, const TriMesh& mesh, const MeshWriteOptions& options) {
  if (options.frame) {
    const Eigen::Matrix3d axes = options.frame->axes;
    const double det = axes.determinant();
    if (!(std::isfinite(det) && det != 0)) throw ParamError(path + ": the patient frame is singular");
    MeshWriteOptions plain = options;
    plain.frame.reset();
    plain.scale = 1.0;
    // Not mirrored: the vertices placed as they are written (no copy of the
    // mesh: the combined mesh of a run is its size again). Mirrored: the
    // triangles reversed in a copy.
    if (det > 0) {
      write_mesh_as(path, mesh, plain, options.ras ? "RAS" : "LPS", &*options.frame);
      return;
    }
    const TriMesh placed = in_patient_space(mesh, *options.frame, options.ras);
    write_mesh_as(path, placed, plain, options.ras ? "RAS" : "LPS");
    return;
  }
  write_mesh_as(path, mesh, options, "");
}

namespace {
void write_mesh_as(const std::string& path, const TriMesh& m, const MeshWriteOptions& options, const std::string& space,
                   const PatientFrame* frame) {
  const double scale = options.scale;
  const std::vector<Rgb>* vertex_colors = options.colors;
  const FormatEntry* format = entry_for(path);
  if (!format) throw ParamError(path + ": " + unknown_format(path));
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
    detail::Out o(path, file.temp_path());
    if (options.triangle_labels && options.triangle_labels->size() != m.triangles.size())
      throw ParamError(path + ": " + std::to_string(options.triangle_labels->size()) + " triangle labels for " +
                       std::to_string(m.triangles.size()) + " triangles");
    format->write(path, o,
                  detail::MeshOut{m, detail::Scaled{m, scale, frame, options.ras}, vertex_colors, options.ascii, space, options.triangle_labels,
                                  options.label, &options.label_names});
    o.close();
  }
  file.commit();
}
}  // namespace

TriMesh read_mesh(const std::string& path, std::vector<Rgb>* vertex_colors) {
  const FormatEntry* format = entry_for(path);
  if (!format) throw InputError(path, unknown_format(path));
  if (!format->read) throw InputError(path, std::string(format->info.name) + " files are written, not read (read .ply, .obj, .stl or .off)");
  return format->read(path, detail::read_file_bytes(path), vertex_colors);
}

TriMesh merge_meshes(const std::vector<const TriMesh*>& parts, const std::vector<Rgb>& part_colors,
                     std::vector<Rgb>* vertex_colors) {
  if (!part_colors.empty() && part_colors.size() != parts.size())
    throw ParamError("merge_meshes: " + std::to_string(part_colors.size()) + " colours for " +
                     std::to_string(parts.size()) + " meshes");
  // Each part's first vertex and triangle in the result; the parts copied side by side.
  std::vector<std::size_t> v0(parts.size() + 1, 0), t0(parts.size() + 1, 0);
  for (std::size_t i = 0; i < parts.size(); ++i)
    v0[i + 1] = v0[i] + parts[i]->vertices.size(), t0[i + 1] = t0[i] + parts[i]->triangles.size();
  TriMesh out;
  out.vertices.resize(v0.back());
  out.triangles.resize(t0.back());
  const bool colour = vertex_colors && !part_colors.empty();
  if (vertex_colors) vertex_colors->assign(colour ? v0.back() : 0, Rgb{});
  tbb::parallel_for(std::size_t(0), parts.size(), [&](std::size_t i) {
    const TriMesh& p = *parts[i];
    const auto offset = std::int32_t(v0[i]);
    std::copy(p.vertices.begin(), p.vertices.end(), out.vertices.begin() + std::ptrdiff_t(v0[i]));
    if (colour) std::fill_n(vertex_colors->begin() + std::ptrdiff_t(v0[i]), p.vertices.size(), part_colors[i]);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, p.triangles.size()), [&](const tbb::blocked_range<std::size_t>& r) {
      for (std::size_t t = r.begin(); t < r.end(); ++t) {
        const auto& a = p.triangles[t];
        out.triangles[t0[i] + t] = {a[0] + offset, a[1] + offset, a[2] + offset};
      }
    });
  });
  return out;
}

TriMesh merge_meshes(const std::vector<TriMesh>& parts, const std::vector<Rgb>& part_colors,
                     std::vector<Rgb>* vertex_colors) {
  std::vector<const TriMesh*> pointers;
  for (const TriMesh& p : parts) pointers.push_back(&p);
  return merge_meshes(pointers, part_colors, vertex_colors);
}

// ---------------------------------------------------------------- PlyPartWriter

namespace {
// Vertices or triangles moved between the scratch file and memory at once
// (12 bytes each: 12 MiB): bounds what write() holds whatever the parts.
constexpr std::size_t kSpillChunk = std::size_t(1) << 20;
}  // namespace

PlyPartWriter::PlyPartWriter(const std::string& scratch_dir) : file_(scratch_dir, "the combined mesh's parts") {}

PlyPartWriter::~PlyPartWriter() = default;

std::size_t PlyPartWriter::add(const TriMesh& m, const std::function<Vec3f(const Vec3f&)>& place, bool flip) {
  const auto put = [&](const void* data, std::size_t bytes) { file_.append(data, bytes); };
  parts_.push_back({file_.size(), m.vertices.size(), m.triangles.size()});
  std::vector<std::array<float, 3>> v;
  for (std::size_t b = 0; b < m.vertices.size(); b += kSpillChunk) {
    v.clear();
    for (std::size_t i = b; i < std::min(m.vertices.size(), b + kSpillChunk); ++i) {
      const Vec3f p = place(m.vertices[i]);
      v.push_back({p.x(), p.y(), p.z()});
    }
    put(v.data(), v.size() * sizeof(v[0]));
  }
  std::vector<std::array<std::int32_t, 3>> t;
  for (std::size_t b = 0; b < m.triangles.size(); b += kSpillChunk) {
    t.clear();
    for (std::size_t i = b; i < std::min(m.triangles.size(), b + kSpillChunk); ++i) {
      const auto& a = m.triangles[i];
      t.push_back(flip ? std::array<std::int32_t, 3>{a[0], a[2], a[1]} : std::array<std::int32_t, 3>{a[0], a[1], a[2]});
    }
    put(t.data(), t.size() * sizeof(t[0]));
  }
  return parts_.size() - 1;
}

namespace {

// The binary PLY of parts (counts[k]: vertices, triangles) in order, each
// part's vertices in colours[k]; `vertices(k, first, chunk)` and
// `triangles(k, first, chunk)` fill a chunk of part k's placed vertices and
// (flipped) triangles, the part's own indices.
template <class Vertices, class Triangles>
void write_ply_of_parts(const std::string& path, const std::vector<std::array<std::size_t, 2>>& counts,
                        const std::vector<Rgb>& colours, const std::string& space, Vertices&& vertices,
                        Triangles&& triangles) {
  std::size_t nv = 0, nt = 0;
  for (const auto& c : counts) nv += c[0], nt += c[1];
  if (nv > std::size_t(std::numeric_limits<std::int32_t>::max())) throw Error(path + ": too many vertices");
  AtomicFile file(path);
  {
    detail::Out o(path, file.temp_path());
    detail::write_ply_header(o, nv, nt, true, false, space);
    std::vector<std::array<float, 3>> v;
    for (std::size_t k = 0; k < counts.size(); ++k) {
      const Rgb c = colours.at(k);
      for (std::size_t b = 0; b < counts[k][0]; b += kSpillChunk) {
        v.resize(std::min(counts[k][0] - b, kSpillChunk));
        vertices(k, b, v);
        for (const auto& x : v) o.bin(x[0], x[1], x[2], c.r, c.g, c.b);
      }
    }
    std::vector<std::array<std::int32_t, 3>> t;
    std::int32_t first = 0;  // the part's first vertex in the file
    for (std::size_t k = 0; k < counts.size(); ++k) {
      for (std::size_t b = 0; b < counts[k][1]; b += kSpillChunk) {
        t.resize(std::min(counts[k][1] - b, kSpillChunk));
        triangles(k, b, t);
        for (const auto& a : t) o.bin(std::uint8_t(3), a[0] + first, a[1] + first, a[2] + first);
      }
      first += std::int32_t(counts[k][0]);
    }
    o.close();
  }
  file.commit();
}

}  // namespace

void PlyPartWriter::write(const std::string& path, const std::vector<std::size_t>& order, const std::vector<Rgb>& colours,
                          const std::string& space) const {
  std::vector<std::array<std::size_t, 2>> counts;
  for (const std::size_t k : order) counts.push_back({parts_.at(k).vertices, parts_.at(k).triangles});
  const auto get = [&](std::int64_t at, auto& chunk) {
    file_.read(at, chunk.data(), chunk.size() * sizeof(chunk[0]));
  };
  write_ply_of_parts(
      path, counts, colours, space,
      [&](std::size_t k, std::size_t b, std::vector<std::array<float, 3>>& v) {
        get(parts_[order[k]].offset + std::int64_t(b * sizeof(v[0])), v);
      },
      [&](std::size_t k, std::size_t b, std::vector<std::array<std::int32_t, 3>>& t) {
        const Part& p = parts_[order[k]];
        get(p.offset + std::int64_t(p.vertices * sizeof(std::array<float, 3>) + b * sizeof(t[0])), t);
      });
}

void write_ply_parts(const std::string& path, const std::vector<PlyPart>& parts, const std::string& space) {
  std::vector<std::array<std::size_t, 2>> counts;
  std::vector<Rgb> colours;
  for (const PlyPart& p : parts) {
    const auto n = std::int64_t(p.mesh->vertices.size());
    for (const auto& t : p.mesh->triangles)
      for (const std::int32_t i : t)
        if (i < 0 || i >= n) throw Error(path + ": a triangle references vertex " + std::to_string(i) + " of " + std::to_string(n));
    counts.push_back({p.mesh->vertices.size(), p.mesh->triangles.size()});
    colours.push_back(p.colour);
  }
  write_ply_of_parts(
      path, counts, colours, space,
      [&](std::size_t k, std::size_t b, std::vector<std::array<float, 3>>& v) {
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, v.size()), [&](const tbb::blocked_range<std::size_t>& r) {
          for (std::size_t i = r.begin(); i < r.end(); ++i) {
            const Vec3f x = parts[k].place(parts[k].mesh->vertices[b + i]);
            v[i] = {x.x(), x.y(), x.z()};
          }
        });
      },
      [&](std::size_t k, std::size_t b, std::vector<std::array<std::int32_t, 3>>& t) {
        for (std::size_t i = 0; i < t.size(); ++i) {
          const auto& a = parts[k].mesh->triangles[b + i];
          t[i] = parts[k].flip ? std::array<std::int32_t, 3>{a[0], a[2], a[1]} : std::array<std::int32_t, 3>{a[0], a[1], a[2]};
        }
      });
}

}  // namespace isoloft
