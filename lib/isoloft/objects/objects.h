// @file objects/objects.h
// @brief Object discovery for reconstruct(): the run every stage shares, the
// label scan (every label's masks from one pass over each slice), the objects
// to reconstruct and their contour stage (paper 2.1). Internals of
// reconstruct(), in detail.
#pragma once

#include <tbb/parallel_for.h>
#include <tbb/task_group.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <exception>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "isoloft/objects/params.h"
#include "isoloft/objects/result.h"
#include "isoloft/objects/slice_fields.h"

namespace isoloft::detail {

using Clock = std::chrono::steady_clock;
inline double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// What every stage of one reconstruct() call shares.
struct Run {
  const SliceStack& stack;
  const ReconstructParams& params;
  const ReconstructOptions& options;
  ReconstructResult& result;
  std::uint32_t label = 0;  ///< the object this part of the run is for (0: the only one, or every label)

  [[nodiscard]] std::size_t slices() const { return stack.slices.size(); }
  void progress(const char* stage, long done, long total) const {
    if (options.progress) options.progress(label, stage, done, total);
  }
  void warn(std::string w) const { result.warnings.push_back(std::move(w)); }
};

// f(slice k) with k's image: the stack's own, or decoded now (lazy stacks).
template <class F>
auto with_slice(const SliceStack& stack, std::size_t k, F&& f) {
  if (!stack.load_image) return f(stack.slices[k]);
  Slice s = stack.slices[k];
  s.image = stack.load_image(k);
  return f(std::as_const(s));
}

// f(k) for the slices [k0, k1) in parallel, reported as `stage` of `total`;
// the first failing slice in order is rethrown, independent of thread timing.
template <class F>
void for_slices(const Run& run, std::size_t k0, std::size_t k1, const char* stage, std::atomic<long>& done, F&& f) {
  std::vector<std::exception_ptr> errors(k1 - k0);
  const long n = long(run.slices());
  tbb::parallel_for(k0, k1, [&](std::size_t k) {
    try {
      f(k);
    } catch (...) {
      errors[k - k0] = std::current_exception();
    }
    run.progress(stage, ++done, n);
  });
  for (const auto& e : errors)
    if (e) std::rethrow_exception(e);
}

// A batch computing ahead in `group` (the caller stopped early, or threw):
// cancelled and waited for, its error dropped (for destructors).
inline void cancel_batch(tbb::task_group& group) noexcept {
  group.cancel();
  try {
    group.wait();
  } catch (...) {
  }
}

/// \throw InputError for < 2 slices, z not increasing or empty images.
void check_stack(const SliceStack& stack);

/// "label L", or "object" for label 0: how warnings name an object.
std::string object_name(std::uint32_t label);

// A label stack's masks (paper 2.1) for every label at once: each slice
// decoded and scanned once (detail::label_masks), not once per label.
struct LabelStackMasks {
  struct Object {
    std::vector<PackedMasks> masks;  // per slice
    std::vector<PixelBox> bounds;
  };
  std::map<std::uint32_t, Object> objects;
  std::optional<Object> uni;  ///< the labels' union, if asked
};

/// Every label's masks and bounds (and the union's bounds and emptiness if
/// `with_union`): each slice decoded and scanned once.
LabelStackMasks label_stack_masks(const Run& run, bool with_union);

/// The objects: one (label 0), or each label of a label stack (those asked
/// for, in the order asked; a label found nowhere is warned of and dropped).
/// \throw ParamError for a label selection without labels input.
std::vector<std::uint32_t> objects_to_reconstruct(const Run& run, const LabelStackMasks* labelled);

/// Stage (paper 2.1): contour and inside of every slice, kept packed until
/// its fields are computed; their union gives obj.box.
std::vector<PackedMasks> contour_stage(const Run& run, ObjectResult& obj);

/// A label's masks from label_stack_masks(), with obj's box and slice count.
std::vector<PackedMasks> label_contours(const Run& run, LabelStackMasks::Object&& labelled, ObjectResult& obj);

}  // namespace isoloft::detail
