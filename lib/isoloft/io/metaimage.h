// @file io/metaimage.h
// @brief MetaImage volumes (.mhd + .raw/.zraw, or one .mha), e.g. the Whole
// Frog: read, and written as .mha. Geometry as ITK's MetaIO keeps it:
// TransformMatrix lists each voxel axis's direction in turn, in patient LPS.
#pragma once

#include <string>

#include "isoloft/io/volume.h"

namespace isoloft {

/// Reads 2D (nz = 1) or 3D scalar data, one channel, local or one data file,
/// raw or zlib, either byte order, spacing and offset.
/// \throw InputError naming the file and the problem, also for a sheared
///        TransformMatrix. NaN samples are kept as they are.
Volume read_metaimage(const std::string& mhd);

/// Writes `v` as one zlib-compressed .mha with its geometry; integer volumes
/// as uint8, uint16 or int32, else float32; atomically.
/// \throw ParamError for another extension; Error naming the path on failure.
void write_metaimage(const std::string& path, const Volume& v);

}  // namespace isoloft
