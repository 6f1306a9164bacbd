// @file mesh/mesh_check.h
// @brief Closedness, manifoldness, orientation, Euler number, volume, area.
// Run on every reconstruction (the report) and in the tests.
#pragma once

#include "isoloft/core/mesh.h"

namespace isoloft {

struct MeshCheck {
  bool closed = false;    ///< no boundary edges
  bool manifold = false;  ///< no edge in > 2 triangles and every vertex star is one fan
  bool oriented = false;  ///< every edge in exactly 2 triangles is used once in each direction
  long boundary_edges = 0;        ///< edges in exactly 1 triangle
  long nonmanifold_edges = 0;     ///< edges in > 2 triangles
  long nonmanifold_vertices = 0;  ///< vertices whose triangles form > 1 fan (edge-connected around the vertex)
  long inconsistent_edges = 0;    ///< edges in 2 triangles that both traverse it in the same direction
  long degenerate_triangles = 0;  ///< a repeated vertex index or exactly zero area
  int components = 0;             ///< connected components (through shared vertices) of the triangles
  long euler = 0;                 ///< V - E + F over the vertices used by triangles
  double volume = 0.0;            ///< signed enclosed volume (pixels^3), > 0 for outward orientation
  double area = 0.0;              ///< total area (pixels^2)
};

/// Checks `mesh` in O(F log F); unused vertices are ignored.
/// \throw InputError if a triangle references a vertex index out of range.
/// @warning A mesh without triangles counts as closed, manifold and oriented.
MeshCheck check_mesh(const TriMesh& mesh);

}  // namespace isoloft
