// @file io/mesh_io.h
// @brief Triangle mesh files by extension: PLY, OBJ, STL, OFF read and
// written; VTK XML PolyData (.vtp) and legacy VTK (.vtk) written.
// Our own exact, one-pass readers and writers (docs/decisions.md).
#pragma once

#include <cstdint>
#include <cstdio>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "isoloft/core/mesh.h"
#include "isoloft/core/scratch_file.h"
#include "isoloft/core/slice_stack.h"

namespace isoloft {

enum class MeshFormat { Ply, Obj, Stl, Off, Vtp, Vtk };

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

/// .ply .obj .stl .off .vtp .vtk, any case. \throw ParamError naming the path otherwise.
MeshFormat mesh_format_from_path(const std::string& path);

/// Writes `m` atomically, coordinates times `scale` (pixels -> physical units):
/// PLY, VTP and VTK binary (ASCII if `ascii`), OBJ and OFF ASCII, STL binary or
/// ASCII without colours; colours per vertex (OBJ "v x y z r g b", COFF).
/// \throw ParamError for an unknown extension, a scale not finite and > 0 or a
///        colour count != vertex count; Error naming the path if writing fails
///        or an index is out of range.
void write_mesh(const std::string& path, const TriMesh& m, double scale = 1.0,
                const std::vector<Rgb>* vertex_colors = nullptr, bool ascii = false);

/// A label in a mesh file and its name (VTK formats: field data).
struct LabelName {
  std::uint32_t label = 0;
  std::string name;  ///< UTF-8; "" when the label has none
};

/// How write_mesh() places and writes the vertices.
struct MeshWriteOptions {
  double scale = 1.0;                 ///< without a frame: coordinates times this
  std::optional<PatientFrame> frame;  ///< working pixels -> patient mm (LPS); overrides scale
  bool ras = false;                   ///< with a frame: RAS (x and y negated) instead of LPS
  const std::vector<Rgb>* colors = nullptr;  ///< one per vertex
  bool ascii = false;
  /// VTK formats: each triangle's label (cell data "Label"), or null: every triangle `label`.
  const std::vector<std::uint32_t>* triangle_labels = nullptr;
  std::uint32_t label = 0;
  /// VTK formats: the labels in the file and their names, as field data
  /// "label" (UInt32) and "label_name" (String), one tuple each per entry, in
  /// this order; empty: none written.
  std::vector<LabelName> label_names;
};

/// write_mesh() with a patient frame: vertices in patient mm, the space named
/// in the header the way 3D Slicer reads it (PLY "comment SPACE=LPS", OBJ and
/// OFF "# SPACE=LPS", STL header "SPACE=LPS"), triangles reversed where the
/// frame mirrors (negative determinant) so they stay counter-clockwise seen
/// from outside. \throw as write_mesh(); ParamError for a singular frame.
void write_mesh(const std::string& path, const TriMesh& m, const MeshWriteOptions& options);

/// The vertices in patient mm (LPS, or RAS: x and y negated), triangles kept
/// counter-clockwise seen from outside where the frame mirrors.
TriMesh in_patient_space(const TriMesh& m, const PatientFrame& frame, bool ras = false);

/// One vertex of in_patient_space(): working pixels -> patient mm (RAS: x and y negated).
inline Vec3f patient_point(const PatientFrame& frame, bool ras, const Vec3f& v) {
  Vec3d p = frame.to_patient(v.cast<double>());
  if (ras) p.x() = -p.x(), p.y() = -p.y();
  return p.cast<float>();
}

/// Reads PLY (ASCII or binary, any scalar types), OBJ, STL (welded by exact
/// position), OFF/COFF; polygons fan-triangulated; colours if present.
/// \throw InputError(path, ...) for a missing, unknown, truncated or corrupt
///        file, an index out of range or a face of < 3 vertices.
TriMesh read_mesh(const std::string& path, std::vector<Rgb>* vertex_colors = nullptr);

/// Concatenates meshes (no welding); part_colors, one per part, become vertex_colors.
/// \throw ParamError if part_colors is non-empty and != parts in size.
TriMesh merge_meshes(const std::vector<TriMesh>& parts, const std::vector<Rgb>& part_colors = {},
                     std::vector<Rgb>* vertex_colors = nullptr);
/// The same for parts held elsewhere (no copy of them), copied side by side.
TriMesh merge_meshes(const std::vector<const TriMesh*>& parts, const std::vector<Rgb>& part_colors = {},
                     std::vector<Rgb>* vertex_colors = nullptr);

/// One part of write_ply_parts(): its mesh, where each vertex goes, whether
/// its triangles are reversed, and its vertices' colour.
struct PlyPart {
  const TriMesh* mesh = nullptr;
  std::function<Vec3f(const Vec3f&)> place;
  bool flip = false;
  Rgb colour;
};

/// The binary PLY of the parts in order, each part's vertices as `place`
/// puts them, in its colour, written from the parts themselves (no merged
/// copy): the bytes write_mesh() writes for merge_meshes() of the placed
/// parts, and PlyPartWriter::write()'s; `space` named as write_mesh() does.
/// 	hrow Error naming `path` if writing fails, there are too many vertices
///        or a triangle references a vertex its part does not have.
void write_ply_parts(const std::string& path, const std::vector<PlyPart>& parts, const std::string& space);

/// A binary PLY of many parts written without holding them (a run's combined
/// mesh, run/outputs.h): add() spills each part's vertices, as `place` puts
/// them, and its triangles to an unnamed scratch file (gone with the writer or
/// the process); write() joins the parts in the order given, each part's
/// vertices in one colour: the bytes write_mesh() writes for merge_meshes()
/// of the placed parts with those colours.
class PlyPartWriter {
 public:
  /// \throw Error naming `scratch_dir` if no scratch file can be made there.
  explicit PlyPartWriter(const std::string& scratch_dir);
  ~PlyPartWriter();
  PlyPartWriter(const PlyPartWriter&) = delete;
  PlyPartWriter& operator=(const PlyPartWriter&) = delete;
  /// Spills `m` (not thread-safe): vertex i as place(m.vertices[i]), each
  /// triangle reversed if `flip`. \return the part's number (0, 1, ...).
  /// \throw Error if the scratch file cannot be written (disk full).
  std::size_t add(const TriMesh& m, const std::function<Vec3f(const Vec3f&)>& place, bool flip);
  /// Writes `path` atomically: parts order[k] (add()'s numbers) coloured
  /// colours[k]; `space` named in the header as write_mesh() does ("": none).
  /// \throw Error naming `path` if writing fails or there are too many vertices.
  void write(const std::string& path, const std::vector<std::size_t>& order, const std::vector<Rgb>& colours,
             const std::string& space) const;

 private:
  struct Part {
    std::int64_t offset = 0;
    std::size_t vertices = 0, triangles = 0;
  };
  ScratchFile file_;
  std::vector<Part> parts_;
};

}  // namespace isoloft
