// @file pipeline.cpp
// @brief reconstruct(): a method with a family of its own runs it
// (MethodSpec::reconstruct, methods/method.h); else the columns family: the
// objects found (objects/objects.h), grouped (one object, or the labels of a
// partition: partition/partition.h), each group streamed
// (methods/columns/column_stream.h), decimated and checked; the results
// joined in object order. Parameter schema: methods/params.cpp.
#include "isoloft/pipeline.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <exception>
#include <numeric>
#include <optional>
#include <utility>

#include "isoloft/core/error.h"
#include "isoloft/core/option_names.h"
#include "isoloft/mesh/mesh_spill.h"
#include "isoloft/partition/partition.h"
#include "isoloft/methods/columns/column_stream.h"
#include "isoloft/objects/objects.h"

namespace isoloft {

namespace {

using detail::Clock;
using detail::Run;
using detail::seconds_since;

// Stage (paper 2.5): bounded quadric error decimation.
void decimate_stage(const Run& run, ObjectResult& obj) {
  const auto t0 = Clock::now();
  obj.triangles_before_decimation = long(obj.mesh.triangles.size());
  if (run.params.decimate.max_error > 0) {
    run.progress("decimate", 0, 1);
    decimate(obj.mesh, run.params.decimate);
    run.progress("decimate", 1, 1);
  }
  run.result.times.decimate += seconds_since(t0);
}

void check_stage(const Run& run, ObjectResult& obj) {
  obj.check = check_mesh(obj.mesh);
  if (run.options.z_slab.count > 1) return;  // open at the cuts: weld_slabs() checks the whole
  if (!obj.check.closed || !obj.check.manifold || !obj.check.oriented)
    run.warn(detail::object_name(obj.label) + ": mesh is not a closed oriented manifold (boundary edges " +
             std::to_string(obj.check.boundary_edges) + ", non-manifold edges " +
             std::to_string(obj.check.nonmanifold_edges) + ")");
}

// What reconstruct() works on: every object's masks and own part of the
// result (warnings, times, joined in object order, so the result is the
// serial one), the groups streamed together (one object, or a label
// partition: its labels, then their union), and the objects the result lists.
struct Plan {
  std::vector<ObjectResult> objects;
  std::vector<std::vector<detail::PackedMasks>> masks;
  std::vector<ReconstructResult> parts;
  std::vector<std::vector<std::size_t>> groups;
  std::vector<std::size_t> listed;  ///< in the order asked (a partition's other labels and union are not)

  [[nodiscard]] Run part(const Run& run, std::size_t i) {
    return Run{run.stack, run.params, run.options, parts[i], objects[i].label};
  }
};

// The objects and their masks (paper 2.1), each estimated before any fit
// (object by object in order; the estimate may throw: over budget). A
// partition needs every label (asked or not) and their union (last).
Plan plan_objects(const Run& run) {
  std::optional<detail::LabelStackMasks> labelled;
  if (run.stack.kind == InputKind::Labels) {
    const auto t0 = Clock::now();
    labelled = detail::label_stack_masks(run, run.params.label_partition);
    run.result.times.contour += seconds_since(t0);
  }
  const std::vector<std::uint32_t> asked = detail::objects_to_reconstruct(run, labelled ? &*labelled : nullptr);
  const bool partition = labelled && run.params.label_partition && labelled->objects.size() >= 2 && !asked.empty();
  std::vector<std::uint32_t> labels = asked;
  if (partition) {
    labels.clear();
    for (const auto& [label, o] : labelled->objects) labels.push_back(label);
  }
  const std::size_t n = labels.size() + (partition ? 1 : 0);
  Plan plan{std::vector<ObjectResult>(n), std::vector<std::vector<detail::PackedMasks>>(n),
            std::vector<ReconstructResult>(n), {}, {}};
  for (std::size_t l = 0; l < n; ++l) {
    ObjectResult& obj = plan.objects[l];
    if (l < labels.size()) obj.label = labels[l];
    const Run part = plan.part(run, l);
    const auto t0 = Clock::now();
    if (l == labels.size()) {  // the union
      plan.masks[l] = detail::label_contours(part, std::move(*labelled->uni), obj);
    } else if (labelled) {
      detail::LabelStackMasks::Object& o = labelled->objects.at(obj.label);
      const bool again = std::find(labels.begin() + std::ptrdiff_t(l) + 1, labels.end(), obj.label) != labels.end();
      plan.masks[l] = detail::label_contours(part, again ? detail::LabelStackMasks::Object(o) : std::move(o), obj);
    } else {
      plan.masks[l] = detail::contour_stage(part, obj);
    }
    plan.parts[l].times.contour += seconds_since(t0);
    if (run.options.on_estimate && obj.slices_with_contours > 0)
      run.options.on_estimate(
          detail::estimate_work(part, plan.masks[l], obj, partition ? detail::partition_slice_window(labels.size()) : 0));
  }
  for (std::size_t i = 0; i < asked.size(); ++i)
    plan.listed.push_back(partition ? std::size_t(std::find(labels.begin(), labels.end(), asked[i]) - labels.begin()) : i);
  if (partition) {
    plan.groups.emplace_back(n);
    std::iota(plan.groups[0].begin(), plan.groups[0].end(), std::size_t(0));
  } else {
    for (std::size_t l = 0; l < n; ++l) plan.groups.push_back({l});
  }
  return plan;
}

// Stages (paper 2.1-2.5) of one group: one object streamed on its own, or a
// label partition streamed in lockstep (its union not meshed); then each
// meshed object decimated and checked. The first failure in object order is
// rethrown.
void group_stages(const Run& run, Plan& plan, const std::vector<std::size_t>& group) {
  if (group.size() == 1) {
    const std::size_t i = group[0];
    ObjectResult& obj = plan.objects[i];
    if (obj.slices_with_contours == 0)
      return plan.part(run, i).warn(detail::object_name(obj.label) + ": no slice has an inside; nothing to reconstruct");
    detail::stream_stages(plan.part(run, i), std::move(plan.masks[i]), obj);
  } else {
    std::vector<detail::PartitionObject> po;
    for (const std::size_t i : group) po.push_back({plan.part(run, i), plan.objects[i], std::move(plan.masks[i])});
    detail::partition_stages(run, po);
  }
  const std::size_t meshed = group.size() == 1 ? 1 : group.size() - 1;
  std::vector<std::exception_ptr> errors(meshed);
  // The largest meshes first (their check and write are the run's tail),
  // each thread taking the next object when done.
  std::vector<std::size_t> order(meshed);
  std::iota(order.begin(), order.end(), std::size_t(0));
  const auto triangles = [&](std::size_t m) {
    const ObjectResult& obj = plan.objects[group[m]];
    return obj.spilled ? obj.spilled->triangles() : obj.mesh.triangles.size();
  };
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return triangles(a) > triangles(b); });
  const auto finish = [&](std::size_t m) {
    ObjectResult& obj = plan.objects[group[m]];
    if (obj.spilled) {  // read back from its scratch file (partition_stages)
      obj.mesh = obj.spilled->load();
      obj.spilled.reset();
    }
    decimate_stage(plan.part(run, group[m]), obj);
    const bool listed = std::find(plan.listed.begin(), plan.listed.end(), group[m]) != plan.listed.end();
    const bool writes = run.options.on_object && listed && obj.slices_with_contours > 0;
    const bool reads = run.options.on_final && !obj.mesh.empty();
    if (!writes && !reads) {
      check_stage(plan.part(run, group[m]), obj);
      return;
    }
    // All only read the mesh: the write and the readers beside the check
    // (the run's serial tail on one object), the mesh freed once all are done.
    tbb::parallel_invoke([&] { check_stage(plan.part(run, group[m]), obj); }, [&] {
      if (reads) run.options.on_final(obj);
      if (writes) run.options.on_object(obj);
    });
    if (writes) obj.free_mesh();
  };
  std::atomic<std::size_t> next{0};
  const std::size_t workers = std::min<std::size_t>(meshed, std::size_t(std::max(1, tbb::this_task_arena::max_concurrency())));
  // Isolated: a thread waiting in the decimator's or check's own tasks
  // does not start another object (and read back another spilled mesh).
  tbb::parallel_for(std::size_t(0), workers, [&](std::size_t) {
    for (std::size_t i; (i = next++) < meshed;)
      tbb::this_task_arena::isolate([&] {
        try {
          finish(order[i]);
        } catch (...) {
          errors[order[i]] = std::current_exception();
        }
      });
  });
  for (const auto& e : errors)
    if (e) std::rethrow_exception(e);
}

// The columns family: the slice fields streamed through the z scheme, with
// the label partition.
ReconstructResult reconstruct_columns(const SliceStack& stack, const ReconstructParams& params,
                                      const ReconstructOptions& options) {
  detail::check_stack(stack);
  params_table<ReconstructParams>().validate(params);
  if (options.z_slab.count > 1 &&
      (options.on_slice_fields || options.on_plane || options.on_sample || params.decimate.max_error > 0))
    throw ParamError(option_name("--z-slab") +
                     ": a slab is part of a surface: no decimation (decimate the joined mesh), stage fields, planes or "
                     "samples (--volume, --labelmap, RT Structure Set out)");
  ReconstructResult result;
  const Run run{stack, params, options, result, 0};
  Plan plan = plan_objects(run);
  // Groups are independent, so they run side by side unless a callback sees
  // them object by object (stage fields, planes, samples).
  const std::size_t n = plan.groups.size();
  std::vector<std::exception_ptr> errors(n);
  auto stages = [&](std::size_t g) {
    try {
      group_stages(run, plan, plan.groups[g]);
    } catch (...) {
      errors[g] = std::current_exception();
    }
  };
  const bool side_by_side = n > 1 && !options.on_slice_fields && !options.on_plane && !options.on_sample;
  if (side_by_side) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1), [&](const tbb::blocked_range<std::size_t>& r) {
      for (std::size_t g = r.begin(); g < r.end(); ++g) stages(g);
    });
  }
  for (std::size_t g = 0; g < n; ++g) {
    if (!side_by_side) stages(g);
    if (errors[g]) std::rethrow_exception(errors[g]);  // the first group's in object order, as run one by one
    for (const std::size_t i : plan.groups[g]) {
      for (auto& w : plan.parts[i].warnings) result.warnings.push_back(std::move(w));
      result.times += plan.parts[i].times;
    }
  }
  for (std::size_t k = 0; k < plan.listed.size(); ++k) {
    const std::size_t i = plan.listed[k];
    if (plan.objects[i].slices_with_contours == 0) continue;
    const bool again = std::find(plan.listed.begin() + std::ptrdiff_t(k) + 1, plan.listed.end(), i) != plan.listed.end();
    result.objects.push_back(again ? plan.objects[i] : std::move(plan.objects[i]));
  }
  return result;
}

}  // namespace

ReconstructResult reconstruct(const MethodInput& in, const ReconstructParams& params, const ReconstructOptions& options) {
  const MethodSpec* m = find_method(params.method.name());
  if (m && m->reconstruct) {
    if (options.z_slab.count > 1)
      throw ParamError(option_name("--z-slab") + ": method " + std::string(params.method.name()) + " has no z slabs (column methods only)");
    MethodInput with_labels = in;
    with_labels.labels = options.labels;
    with_labels.on_estimate = options.on_estimate;
    return m->reconstruct(with_labels, params);
  }
  return reconstruct_columns(in.stack, params, options);
}

ReconstructResult reconstruct(const SliceStack& stack, const ReconstructParams& params, const ReconstructOptions& options) {
  const std::vector<Section> none;
  return reconstruct(MethodInput{stack, none, 0}, params, options);
}

}  // namespace isoloft
