// @file io/nifti.h
// @brief NIfTI-1/-2 label and scalar volumes (.nii, .nii.gz, .hdr/.img) via
// niftilib, in DICOM patient space (LPS, mm).
//
// Geometry: the sform when sform_code > 0, else the qform when qform_code >
// 0, else NIfTI's method 1 (x = i dx, y = j dy, z = k dz, taken as RAS). Both
// forms are RAS (x right, y anterior): patient LPS is diag(-1, -1, 1) of it.
// Values: scl_slope and scl_inter applied when the slope is not 0 (the
// standard's "no scaling").
#pragma once

#include <string>

#include "isoloft/io/volume.h"

namespace isoloft {

/// Reads one 3D (or 2D, as nz = 1) scalar volume; 32-bit integer labels
/// stay exact (Volume::value_table).
/// \throw InputError naming the file for: an unreadable, truncated or corrupt
///        file (a .nii.gz whose gzip checksum fails included, with zlib's
///        reason), a missing .img beside a .hdr, sizes beyond 2^31 - 1 (NIfTI-2),
///        more than one volume (4D/5D with a size > 1 beyond z),
///        complex/RGB/64-bit integer data, a voxel size that is not finite and
///        > 0, a singular or sheared affine; what options.on_header throws.
///        NaN samples are kept as they are.
/// @warning Neither sform nor qform (method 1): the axes are taken as RAS and
///          Volume::warnings says so.
Volume read_nifti(const std::string& path, const VolumeReadOptions& options = {});

/// Writes `v` as NIfTI-1 (.nii or .nii.gz by the name), sform and qform
/// both set from its geometry (code 1, scanner anatomical), values as uint8,
/// uint16, int32 or uint32 when integer and in range, else float32; atomically.
/// \throw Error naming the path if writing fails.
void write_nifti(const std::string& path, const Volume& v);

}  // namespace isoloft
