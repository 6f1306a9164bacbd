// @file io/metaimage.h
// @brief MetaImage volumes (.mhd + .raw/.zraw, or one .mha), e.g. the Whole
// Frog: read, and written as .mha. Geometry as ITK's MetaIO keeps it:
// TransformMatrix lists each voxel axis's direction in turn, in patient LPS.
#pragma once

#include <string>

#include "isoloft/io/volume.h"

namespace isoloft {

/// Reads 2D (nz = 1) or 3D scalar data, one channel, local or one data file
/// (in the header's folder or below unless options.allow_external_data),
/// binary (raw or zlib, either byte order) or ASCII (BinaryData = False),
/// spacing and offset; 32-bit integer labels stay exact (Volume::value_table).
/// \throw InputError naming the file and the problem, also for a sheared
///        TransformMatrix, a header line after ElementDataFile = LOCAL, data
///        of another size than the header declares; what options.on_header
///        throws. NaN samples are kept as they are.
Volume read_metaimage(const std::string& mhd, const VolumeReadOptions& options = {});

/// Writes `v` as one zlib-compressed .mha with its geometry; integer volumes
/// as uint8, uint16, int32 or uint32, else float32; atomically.
/// \throw ParamError for another extension; Error naming the path on failure.
void write_metaimage(const std::string& path, const Volume& v);

}  // namespace isoloft
