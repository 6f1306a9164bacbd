// @file io/dicom_series.h
// @brief The grid of a DICOM image series (a CT or MR series folder, DCMTK):
// size, spacing, origin and direction cosines from each file's Image Plane
// module (headers only; the pixel data is never read).
//
// Voxel (i, j, k) is column i, row j of the k-th slice in order along the
// slice normal (ImageOrientationPatient's row x column direction), at
// patient (LPS, mm) position origin + direction * (i sx, j sy, k sz): sx is
// the spacing between columns (PixelSpacing's second value), sy between rows.
#pragma once

#include <string>
#include <vector>

#include "isoloft/io/volume.h"

namespace isoloft {

struct DicomSeries {
  Volume grid;                     ///< geometry only: data is empty
  std::string frame_of_reference;  ///< FrameOfReferenceUID ("" if absent)
  std::string series_uid;          ///< SeriesInstanceUID
  std::string modality;            ///< Modality (CT, MR, ...)
  std::string sop_class_uid;       ///< of the slices
  std::vector<std::string> sop_instance_uids;  ///< per slice k
  std::vector<std::string> files;              ///< per slice k
};

/// Reads the grid of one single-frame DICOM image series: `path` a folder
/// (its DICOM files that carry an image plane; other files, e.g. an RT
/// Structure Set beside the CT, are passed over) or one file of the series
/// (the files of its folder with its SeriesInstanceUID).
/// \throw InputError naming `path` and the problem: no DICOM image file;
///        several series in the folder (listed with their UIDs, modality,
///        description and slice count: give one file of the wanted series);
///        a multi-frame image; slices differing in size, pixel spacing or
///        orientation; two slices at one position; steps between slices not
///        even (the steps listed: a missing slice?); positions that drift
///        sideways from the slice normal (a gantry tilt): not a regular grid.
DicomSeries read_dicom_series(const std::string& path);

/// Slice steps may differ from their median by this share (and at least
/// kSeriesPositionToleranceMm): positions are decimal strings.
inline constexpr double kSeriesStepTolerance = 0.01;
/// Positions may drift this far (mm) from the line along the slice normal.
inline constexpr double kSeriesPositionToleranceMm = 0.01;

}  // namespace isoloft
