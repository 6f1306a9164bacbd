// @file mesh/slab_join.h
// @brief One object's z slab meshes (ReconstructOptions::z_slab) joined into
// its surface: each pair of neighbouring slabs shares its cut plane, whose
// samples both computed bit for bit, so the vertices there coincide exactly;
// they are welded by position, boundary vertex to boundary vertex.
// @warning A vertex on a cut with no partner (slabs from different runs or
// parameters) stays open: the result's check counts its boundary edges.
#pragma once

#include <vector>

#include "isoloft/core/mesh.h"
#include "isoloft/mesh/mesh_check.h"

namespace isoloft {

struct SlabJoinResult {
  TriMesh mesh;          ///< the parts' triangles, the cut vertices welded
  long welded = 0;       ///< vertex pairs welded across cuts
  long unmatched = 0;    ///< boundary vertices of a part with no partner in its neighbour
  MeshCheck check;       ///< of the joined mesh: closed where every cut welded
};

/// Joins the slab meshes of one object, bottom up (empty parts allowed).
/// Part s's boundary vertices are welded to part s + 1's at the same
/// position (bit for bit); two boundary vertices of one part at one position
/// pair in index order.
SlabJoinResult join_slabs(const std::vector<TriMesh>& parts);

}  // namespace isoloft
