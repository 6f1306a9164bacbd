// @file io/label_names.h
// @brief The names of a label map's labels, from the table its atlas or
// tool ships beside it: AAL / mricron `.nii.txt` ("1 Precentral_L 2001"),
// FreeSurfer's LUT and 3D Slicer's `.ctbl` ("17 Left-Hippocampus 220 216 20
// 0"), ITK-SNAP label descriptions ("1 255 0 0 1 1 1 \"Left lung\"").
//
// One reader for all: a line is a label number, then a quoted name (ITK-SNAP)
// or the next token (names without blanks: AAL, FreeSurfer, Slicer); '#'
// comment lines and blank lines skipped; label 0 (the background, "Clear
// Label", "Unknown") is not an object and is skipped. Names are UTF-8 (a BOM
// skipped) and kept as written (file names take them through file_safe()). mricron's `.lut` files are 768-byte colour tables without names.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>

namespace isoloft {

struct LabelNames {
  std::string file;                             ///< the table read
  std::map<std::uint32_t, std::string> names;  ///< label -> name (label 0 not listed)
  /// The label's name, or "" if the table has none.
  [[nodiscard]] std::string name(std::uint32_t label) const;
};

/// Reads a label table (see the file comment).
/// \throw InputError naming `path` and the line: a line that does not start
///        with a label number (0 .. 2^32 - 1) or has no name; an unclosed
///        quote; a NUL byte or text that is not UTF-8; one label named twice
///        differently (both lines named); a table with no label; a file
///        that is not a regular file or larger than kMaxLabelTableBytes.
LabelNames read_label_names(const std::string& path);

/// Label tables are text of a few hundred lines (AAL 116, FreeSurfer's LUT
/// 1,300): a larger file is not one.
inline constexpr std::size_t kMaxLabelTableBytes = 16u << 20;

/// The table beside label volume `volume`: the first existing regular file
/// of <volume>.txt (aal.nii.txt for aal.nii.gz: the name without .gz),
/// <stem>.txt, <stem>.ctbl, <stem>_labels.txt, <stem>.label; nullopt if none.
[[nodiscard]] std::optional<std::string> label_names_beside(const std::string& volume);

}  // namespace isoloft
