// @file run/budget.h
// @brief A run's work budget (--max-memory, --max-output): estimates checked
// before the work they count, so an oversized or hostile input stops with an
// error naming the option and the estimate instead of exhausting the machine
// (docs/decisions.md, work budget).
//
// Checked: the slice images' size from their headers, before decoding
// (read_inputs); the input's footprint through the contour stage, after
// reading; per object after its contour stage and before its fit, its
// fields and mesh (memory; the meshes of all objects so far count too, as
// the run holds them until it writes them) and the bytes of every file the
// run writes for it (output; each RunOutput counts its own); before the
// work, the number of files the run will write and that no two share a name.
#pragma once

#include <string>

#include "isoloft/core/slice_stack.h"

namespace isoloft {

struct Inputs;

/// Most files one run writes by default (--max-files): a label map of 65,535
/// labels would otherwise write 65,537 files over minutes of work.
inline constexpr long kDefaultMaxFiles = 4096;

/// Limits, 0 = no limit.
struct Budget {
  double max_memory = 0;  ///< --max-memory, bytes: per object and per run (meshes held until written; a partition's fields)
  double max_output = 0;  ///< --max-output, bytes
  long max_files = 0;     ///< --max-files: files planned before the work (meshes, volumes, label map, report)
};

/// The CLI's default for both (4 GiB).
inline constexpr const char* kDefaultBudget = "4G";

/// A byte count from "4G", "512M", "64K", "1.5G" (binary units) or plain
/// bytes; 0 = no limit. \throw ParamError naming `option`.
double parse_size(const std::string& text, const std::string& option);
/// E.g. "3.2 GiB", "512 MiB".
std::string size_text(double bytes);
/// \throw ParamError "<option>: <what> needs about X, over the budget of Y ..." if need > limit > 0.
void check_budget(const std::string& option, const std::string& what, double need, double limit);

/// Bytes one stack holds up to and through the contour stage: its held
/// slice images (volumes; PNG slices are decoded as the pipeline goes), its
/// packed masks and, per slice in flight, a decoded image, the full-size
/// masks and the fill's temporaries.
double stack_bytes(const SliceStack& stack);

/// The largest stack_bytes() of the jobs (they run one at a time) plus a
/// volume input's voxels.
double input_bytes(const Inputs& in);

/// Bytes a label map holds per voxel of its grid when it is written: its
/// float volume (4) and the encoded copy the writer makes (int32 at most, 4),
/// plus the objects' inside bits (a byte per voxel, one object's worth).
inline constexpr double kLabelmapBytesPerVoxel = 9;

/// This machine's physical memory in bytes (0 if unknown).
double physical_memory_bytes();

/// check_budget(), and with no limit (0) the machine's physical memory is the
/// limit: for what a run must hold whatever its objects (a label map on a
/// 65535 x 65535 x 100 grid), an error before the work instead of running
/// out of memory at its end. \throw ParamError naming `option`.
void check_held_memory(const std::string& option, const std::string& what, double need, double limit);

/// Bytes per triangle of a mesh file: binary STL (50, the largest binary
/// format) and ASCII STL (~250, the largest text one), upper bounds for PLY,
/// OBJ and OFF.
inline constexpr double kMeshFileBytesPerTriangle = 50, kAsciiMeshFileBytesPerTriangle = 250;

}  // namespace isoloft
