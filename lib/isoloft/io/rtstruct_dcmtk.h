// @file io/rtstruct_dcmtk.h
// @brief DCMTK helpers shared by the RT Structure Set reader and writer
// (internal to io/rtstruct_*.cpp: the only files that include DCMTK).
#pragma once

// DCMTK's configuration header must come before its other headers.
#include "dcmtk/config/osconfig.h"
#include "dcmtk/dcmdata/dcfilefo.h"

#include <functional>
#include <string>
#include <vector>

namespace isoloft::detail {

/// A DICOM file parsed from its bytes (read once, never again from disk),
/// through an anonymous in-memory file: DCMTK checks an element's length
/// against what a file holds (from a buffer stream it allocates what a lying
/// length asks first). Long values are loaded before the file closes.
OFCondition load_dicom(DcmFileFormat& ff, const std::vector<unsigned char>& bytes);

/// Runs `build`; returns dcmrt's warnings and errors logged meanwhile (DCMTK
/// names the attribute a structure set lacks only in its log).
std::string dcmrt_log(const std::function<void()>& build);

}  // namespace isoloft::detail
