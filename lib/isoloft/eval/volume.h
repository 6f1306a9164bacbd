// @file eval/volume.h
// @brief Volume ratios for the tilted-tube kit (experiments/tilted_tubes.cpp), as
// the tilted-tube kit defines them: the samples inside
// a closed mesh over those inside the analytic truth, at every pixel centre
// (x, y whole) and every kVolumeSampleStep in z over the slice range. At the
// slices this counts what the masks can show (a pixel is in a mask iff its
// centre is inside), so the input's pixelation cancels there.
// The mesh's side of a point by the parity of its crossings along z.
#pragma once

#include "isoloft/core/mesh.h"
#include "isoloft/synth/shapes.h"

namespace isoloft {

/// Points origin + (i step_xy, j step_xy, k step_z), 0 <= i < nx, ...
struct SampleGrid {
  Vec3d origin{0, 0, 0};
  double step_xy = 1, step_z = 1;
  int nx = 0, ny = 0, nz = 0;
};

/// Points inside a closed mesh: an odd number of crossings above them.
/// @warning A column through a vertex or an edge may count it twice or not at
/// all: place the grid off the mesh's vertex coordinates (volume_ratio moves
/// its columns kColumnJitter off the whole pixels where Marching Cubes puts them).
long mesh_inside_samples(const TriMesh& mesh, const SampleGrid& grid);
/// Points where shape.value() > 0.
long shape_inside_samples(const Shape& shape, const SampleGrid& grid);

/// z spacing of volume_ratio()'s samples, px (the kit's).
inline constexpr double kVolumeSampleStep = 0.5;
/// volume_ratio()'s mesh columns lie this far off the pixel centres, px:
/// Marching Cubes' vertices on whole-pixel lines are kept 1e-4 of an edge
/// away from the grid points, so the columns miss them, and the count moves
/// by less than a sample in 10^4.
inline constexpr double kColumnJitter = 1.7e-5;

/// Inside samples of the mesh over those of the truth: pixel centres of a
/// width x height image, z from z_first to z_last every kVolumeSampleStep.
double volume_ratio(const TriMesh& mesh, const Shape& truth, int width, int height, double z_first, double z_last);

}  // namespace isoloft
