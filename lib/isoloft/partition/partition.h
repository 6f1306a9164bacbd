// @file partition/partition.h
// @brief The label partition (ReconstructParams::label_partition): touching
// labels as one partition of space. Every label's field and the union's
// streamed in lockstep; at every plane and sample height label l's field
// becomes psi_l = phi_l - max(phi_m (m != l), -phi_union), positive where l's
// field is the highest of the labels' and the background's. So neighbours l
// and m share the zero set of psi_l = -psi_m = phi_l - phi_m, a point inside
// the union goes to its nearest label, and a label that meets only the
// background keeps its own surface (there phi_union = phi_l).
#pragma once

#include <vector>

#include "isoloft/objects/objects.h"

namespace isoloft::detail {

// One object of a label partition: its own Run (warnings, times), result and masks.
struct PartitionObject {
  Run run;
  ObjectResult& obj;
  std::vector<PackedMasks> masks;
};

/// Stages (paper 2.1-2.5 but decimation) of a label partition: every object
/// but the last is a label, meshed into its ObjectResult; the last is the
/// labels' union (label_stack_masks(with_union)), not meshed.
void partition_stages(const Run& run, std::vector<PartitionObject>& objects);

}  // namespace isoloft::detail
