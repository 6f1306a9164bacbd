// @file io/metaimage.h
// @brief MetaImage (.mhd + .raw/.zraw) volumes, e.g. the Whole Frog. Read only.
#pragma once

#include <string>

#include "isoloft/io/volume.h"

namespace isoloft {

/// Reads 2D (nz = 1) or 3D scalar data, one channel, local or one data file,
/// raw or zlib, either byte order, spacing and offset.
/// \throw InputError naming the file and the problem, also for a
///        TransformMatrix other than the identity.
Volume read_metaimage(const std::string& mhd);

}  // namespace isoloft
