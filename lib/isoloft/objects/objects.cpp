// @file objects/objects.cpp
// @brief Object discovery and the contour stage of reconstruct() (objects/objects.h).
#include "isoloft/objects/objects.h"

#include <algorithm>
#include <set>

#include "isoloft/core/error.h"

namespace isoloft::detail {

void check_stack(const SliceStack& stack) {
  if (stack.slices.empty()) throw InputError("", "no slices");
  if (stack.slices.size() < 2)
    throw InputError(stack.slices.front().source, "only one slice; a reconstruction needs at least 2 slices");
  for (std::size_t k = 1; k < stack.slices.size(); ++k)
    if (!(stack.slices[k].z > stack.slices[k - 1].z))
      throw InputError(stack.slices[k].source, "slice z must increase strictly (z = " + std::to_string(stack.slices[k].z) +
                                                   " after " + std::to_string(stack.slices[k - 1].z) + ")");
  if (stack.width < 1 || stack.height < 1) throw InputError("", "empty slice images");
}

std::string object_name(std::uint32_t label) { return label ? "label " + std::to_string(label) : "object"; }

LabelStackMasks label_stack_masks(const Run& run, bool with_union) {
  const std::size_t n = run.slices();
  std::vector<std::vector<LabelMasks>> per_slice(n);
  std::atomic<long> done{0};
  for_slices(run, 0, n, "contour", done, [&](std::size_t k) {
    with_slice(run.stack, k, [&](const Slice& s) { per_slice[k] = label_masks(s.image); });
  });
  LabelStackMasks out;
  if (with_union) {
    // The union's bounds and emptiness (its field comes from the labels': UnionStream).
    out.uni.emplace();
    for (const auto& slice : per_slice) {
      PixelBox b{run.stack.width, run.stack.height, -1, -1};
      for (const auto& m : slice)
        b = {std::min(b.x0, m.bounds.x0), std::min(b.y0, m.bounds.y0), std::max(b.x1, m.bounds.x1), std::max(b.y1, m.bounds.y1)};
      out.uni->masks.push_back(PackedMasks{run.stack.width, run.stack.height, slice.empty(), {}, {}});
      out.uni->bounds.push_back(slice.empty() ? PixelBox{} : b);
    }
  }
  for (std::size_t k = 0; k < n; ++k)
    for (auto& m : per_slice[k]) {
      auto [it, added] = out.objects.try_emplace(m.label);
      if (added) {
        it->second.masks.assign(n, PackedMasks{run.stack.width, run.stack.height, true, {}, {}});
        it->second.bounds.assign(n, PixelBox{});
      }
      it->second.masks[k] = std::move(m.masks);
      it->second.bounds[k] = m.bounds;
    }
  return out;
}

// The objects: one (label 0), or each label of a label stack (those asked for).
std::vector<std::uint32_t> objects_to_reconstruct(const Run& run, const LabelStackMasks* labelled) {
  const std::vector<std::uint32_t>& asked = run.options.labels;
  if (run.stack.kind != InputKind::Labels) {
    if (!asked.empty()) throw ParamError("labels: a label selection needs labels input (InputKind::Labels)");
    return {0};
  }
  std::set<std::uint32_t> seen;
  for (const auto& [label, object] : labelled->objects) seen.insert(label);
  std::vector<std::uint32_t> labels(seen.begin(), seen.end());
  if (!asked.empty()) {
    std::vector<std::uint32_t> keep;
    for (auto l : asked) {
      if (seen.count(l)) keep.push_back(l);
      else run.warn("label " + std::to_string(l) + " does not occur in any slice");
    }
    labels = std::move(keep);
  }
  if (labels.empty()) run.warn("no labels to reconstruct (every slice is 0)");
  return labels;
}

void finish_contours(const Run& run, const std::vector<PackedMasks>& masks, const std::vector<PixelBox>& bounds,
                     ObjectResult& obj) {
  obj.slices_with_contours = int(std::count_if(masks.begin(), masks.end(), [](const auto& m) { return !m.empty; }));
  obj.box = object_box(bounds, run.stack.width, run.stack.height, run.params.crop_margin);
}

// Stage (paper 2.1): contour and inside of every slice, kept packed until
// its fields are computed; their union gives the crop box.
std::vector<PackedMasks> contour_stage(const Run& run, ObjectResult& obj) {
  const std::size_t n = run.slices();
  std::vector<PackedMasks> masks(n);
  std::vector<PixelBox> bounds(n);
  std::vector<std::vector<std::string>> warnings(n);
  std::atomic<long> done{0};
  for_slices(run, 0, n, "contour", done, [&](std::size_t k) {
    SliceMasks m =
        with_slice(run.stack, k, [&](const Slice& s) { return slice_masks(run.stack, s, run.params, obj.label); });
    bounds[k] = mask_bounds(m);
    warnings[k] = std::move(m.warnings);
    masks[k] = pack_masks(m);
  });
  for (auto& w : warnings)
    for (auto& line : w) run.warn(std::move(line));
  finish_contours(run, masks, bounds, obj);
  return masks;
}

// A label's masks from label_stack_masks.
std::vector<PackedMasks> label_contours(const Run& run, LabelStackMasks::Object&& labelled, ObjectResult& obj) {
  finish_contours(run, labelled.masks, labelled.bounds, obj);
  return std::move(labelled.masks);
}

}  // namespace isoloft::detail
