// @file mesh/plane_cut.h
// @brief Where a plane z = const cuts a closed mesh: closed polygons, as an
// RT Structure Set holds a surface (io/rtstruct.h, write_rtstruct).
// A vertex exactly on the plane counts as above it (symbolic perturbation),
// so a plane through vertices, as Marching Cubes puts them on its sampled
// planes, still gives closed simple loops: the in-plane edges of the
// triangles below it.
#pragma once

#include <vector>

#include "isoloft/core/mesh.h"

namespace isoloft {

/// The loops (x, y) where the plane z = `z` cuts `mesh`, each closed (the
/// last point joins the first), counter-clockwise seen from +z around the
/// inside for a mesh oriented counter-clockwise seen from outside (holes
/// clockwise). Consecutive equal points are merged; loops of fewer than 3
/// points dropped.
/// @warning A mesh with boundary or non-manifold edges may give open chains:
/// they are dropped.
std::vector<std::vector<Vec2d>> cut_mesh(const TriMesh& mesh, double z);

}  // namespace isoloft
