// MetaImage (ITK/VTK .mhd + .raw/.zraw, https://itk.org/Wiki/ITK/MetaIO/Documentation)
// label maps and intensity volumes, e.g. the Whole Frog label map. Read only.
#pragma once

#include <string>

#include "isoloft/io/volume.h"

namespace isoloft {

/// Read a MetaImage header and its data into a float Volume.
/// Supported: NDims 2 or 3 (2D as nz = 1); ElementType MET_(U)CHAR,
/// MET_(U)SHORT, MET_(U)INT, MET_FLOAT, MET_DOUBLE; ElementNumberOfChannels 1;
/// ElementDataFile LOCAL or one file relative to the header (CompressedData =
/// True: zlib inflate; HeaderSize for raw data, -1 = data at the file's end);
/// BinaryDataByteOrderMSB / ElementByteOrderMSB; ElementSpacing (else
/// ElementSize); Offset (else Position / Origin). TransformMatrix must be the
/// identity (rotated volumes are not supported).
/// \throw InputError(path, ...) naming the header or data file and the problem.
Volume read_metaimage(const std::string& mhd);

}  // namespace isoloft
