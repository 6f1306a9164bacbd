// @file mesh/mesh_spill.h
// @brief A mesh built piece by piece into two unnamed scratch files
// (vertices, triangles; core/scratch_file.h) and read back whole: a label
// partition's meshes kept out of memory while its labels stream together.
// The pieces are appended in order, so the mesh read back is the one built,
// bit for bit.
#pragma once

#include <cstddef>
#include <string>

#include "isoloft/core/mesh.h"
#include "isoloft/core/scratch_file.h"

namespace isoloft {

class MeshSpill {
 public:
  /// \throw Error naming `dir` if no scratch file can be made there.
  explicit MeshSpill(const std::string& dir);

  /// Appends m's vertices and triangles (its indices already the whole
  /// mesh's), then clears m, keeping its capacity.
  void take(TriMesh& m);
  [[nodiscard]] std::size_t vertices() const { return nv_; }
  [[nodiscard]] std::size_t triangles() const { return nt_; }
  /// Everything appended, as one mesh.
  [[nodiscard]] TriMesh load() const;

 private:
  ScratchFile v_, t_;
  std::size_t nv_ = 0, nt_ = 0;
};

}  // namespace isoloft
