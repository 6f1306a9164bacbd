// Triangle mesh files: PLY (binary little-endian or ASCII), OBJ, STL (binary or
// ASCII) and OFF, chosen by the file extension.
//
// Hand-written rather than OpenMesh IO: OpenMesh loads into a halfedge mesh,
// which drops non-manifold faces ("complex edge") and so cannot read back
// exactly what Marching Cubes wrote or what a metric must compare; writing
// per-vertex colours with it means copying into an OpenMesh mesh with colour
// properties first. Straight array writers are one pass, streaming and exact.
// The tests read our files with OpenMesh to check they are standard.
//
// Formats: PLY http://paulbourke.net/dataformats/ply/, OBJ (Wavefront),
// STL (3D Systems), OFF/COFF (Geomview).
#pragma once

#include <string>
#include <vector>

#include "isoloft/core/mesh.h"

namespace isoloft {

enum class MeshFormat { Ply, Obj, Stl, Off };

/// What a mesh format supports (the dispatcher's table, io/mesh_io.cpp).
struct MeshFormatInfo {
  MeshFormat format;
  const char* extension;  ///< lower case, with the dot
  const char* name;
  bool colors;     ///< per-vertex colours written and read
  bool binary;     ///< a binary flavour (the default; ASCII if asked)
  bool readable;   ///< read_mesh() reads it
};

/// Every format, in the table's order.
std::vector<MeshFormatInfo> mesh_formats();

/// Format from the (case-insensitive) extension: .ply .obj .stl .off.
/// \throw ParamError naming the path for any other extension.
MeshFormat mesh_format_from_path(const std::string& path);

/// Write `m` atomically (see atomic_file.h) with every coordinate multiplied
/// by `scale` (pixel units -> physical units).
/// - .ply: binary little-endian (ASCII if `ascii`), colours as uchar red/green/blue;
/// - .obj: always ASCII; colours as the common "v x y z r g b" extension (0..1);
/// - .stl: binary (ASCII if `ascii`) with facet normals; colours not written;
/// - .off: always ASCII; with colours the header is COFF ("x y z r g b 255").
/// ASCII numbers use the shortest form that reads back to the same float.
/// \pre every triangle index is in [0, vertices.size()).
/// \throw ParamError for an unknown extension, scale not finite and > 0, or
/// vertex_colors->size() != m.vertices.size(); Error naming the path if
/// writing fails or a triangle index is out of range.
void write_mesh(const std::string& path, const TriMesh& m, double scale = 1.0,
                const std::vector<Rgb>* vertex_colors = nullptr, bool ascii = false);

/// Read a mesh by extension: PLY (ASCII, binary little/big-endian; any scalar
/// type for x/y/z; any list types for vertex_indices / vertex_index; other
/// elements skipped), OBJ (v, f with v/vt/vn and negative indices), STL
/// (binary or ASCII; vertices welded by exact position), OFF / COFF.
/// Polygons are fan-triangulated. If `vertex_colors` is given it receives the
/// per-vertex colours of PLY/OBJ/COFF files, or is cleared if there are none.
/// \throw InputError(path, ...) for a missing, unknown, truncated or corrupt
/// file, an index out of range or a face with fewer than 3 vertices.
TriMesh read_mesh(const std::string& path, std::vector<Rgb>* vertex_colors = nullptr);

/// Concatenate meshes (indices offset, no welding). If `part_colors` is
/// non-empty it gives one colour per part and `vertex_colors` (if given)
/// receives the matching per-vertex colours for write_mesh.
/// \throw ParamError if part_colors is non-empty and its size != parts.size().
TriMesh merge_meshes(const std::vector<TriMesh>& parts, const std::vector<Rgb>& part_colors = {},
                     std::vector<Rgb>* vertex_colors = nullptr);

}  // namespace isoloft
