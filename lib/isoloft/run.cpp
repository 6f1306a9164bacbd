#include "isoloft/run.h"

#include <sys/resource.h>
#include <tbb/global_control.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <filesystem>
#include <array>
#include <atomic>
#include <chrono>
#include <exception>
#include <numeric>
#include <map>
#include <mutex>
#include <cmath>
#include <sstream>

#include "isoloft/core/error.h"
#include "isoloft/core/option_names.h"
#include "isoloft/io/atomic_file.h"
#include "isoloft/methods/method.h"
#include "isoloft/objects/objects.h"
#include "isoloft/run/volume_table.h"

namespace isoloft {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// "ROI 'Heart': label 3 (40 z planes of 120x96 px, ~51234 triangles)", or
// for field3d "label 3 of seg.nrrd (field3d: a 97x89x81 grid, 412345
// samples, ~51234 triangles)": the object a budget error or the activity names.
std::string object_text(const Inputs& in, const Job& job, const WorkEstimate& e) {
  std::ostringstream what;
  what << (job.name.empty() ? "" : "ROI '" + job.name + "': ") << (e.label ? "label " + std::to_string(e.label) : "the object");
  if (e.grid[0] > 0) {
    if (!in.files.empty()) what << " of " << in.files.front();
    what << " (field3d: a " << e.grid[0] << "x" << e.grid[1] << "x" << e.grid[2] << " grid, " << std::llround(e.samples)
         << " samples, ~" << std::llround(e.triangles) << " triangles)";
    return what.str();
  }
  what << " (" << e.planes << " z planes of " << e.box.width() << "x" << e.box.height() << " px, ~" << e.triangles
       << " triangles)";
  return what.str();
}

// The objects the run will make, before any work: each label in a label
// input's slices (those asked for), else one per job.
std::vector<PlannedObject> planned_objects(const Inputs& in, const std::vector<std::uint32_t>& asked) {
  std::vector<PlannedObject> out;
  if (!in.labels()) {
    for (std::size_t j = 0; j < in.jobs.size(); ++j) out.push_back({j, 0});
    return out;
  }
  // Slices side by side (lazy stacks decode each image now); the first
  // failing slice in order is rethrown.
  const std::size_t n = in.first().slices.size();
  std::vector<std::vector<std::uint32_t>> per_slice(n);
  std::vector<std::exception_ptr> errors(n);
  tbb::parallel_for(std::size_t(0), n, [&](std::size_t k) {
    try {
      detail::with_slice(in.first(), k, [&](const Slice& s) {
        std::vector<std::uint32_t>& seen = per_slice[k];
        std::uint32_t last = 0;  // labels come in runs: most pixels repeat their neighbour
        for (const std::uint32_t v : s.image.data)
          if (v != 0 && v != last) seen.push_back(last = v);
        std::sort(seen.begin(), seen.end());
        seen.erase(std::unique(seen.begin(), seen.end()), seen.end());
      });
    } catch (...) {
      errors[k] = std::current_exception();
    }
  });
  for (const auto& e : errors)
    if (e) std::rethrow_exception(e);
  std::vector<std::uint32_t> seen;
  for (const auto& labels : per_slice) seen.insert(seen.end(), labels.begin(), labels.end());
  std::sort(seen.begin(), seen.end());
  seen.erase(std::unique(seen.begin(), seen.end()), seen.end());
  for (const std::uint32_t l : seen)
    if (asked.empty() || std::find(asked.begin(), asked.end(), l) != asked.end()) out.push_back({0, l});
  return out;
}

// Before any work: how many files the run writes, and every output path
// resolved (check_output_paths: no input, params file or device replaced,
// no two writers on one file).
void check_planned_files(const Inputs& in, const RunOptions& o) {
  const std::vector<PlannedObject> objects = planned_objects(in, o.labels);
  std::vector<PlannedFile> files, dirs;
  for (const auto& out : o.outputs) {
    for (PlannedFile& f : out->planned_files(in, objects)) {
      f.option = out->option();
      files.push_back(std::move(f));
    }
    if (const std::string dir = out->output_directory(); !dir.empty()) dirs.push_back({dir, out->option(), out->option()});
  }
  if (!o.report_path.empty()) files.push_back({o.report_path, option_name("--report"), "--report"});
  if (o.budget.max_files > 0 && long(files.size()) > o.budget.max_files)
    throw ParamError(option_name("--max-files") + ": the run would write " + std::to_string(files.size()) +
                     " files (" + std::to_string(objects.size()) + (in.labels() ? " labels" : " objects") +
                     "), over the limit of " + std::to_string(o.budget.max_files) + "; select labels with " +
                     option_name("--labels") + " or raise " + option_name("--max-files") + " (0 = no limit)");
  std::vector<ReadFile> reads = o.read_files;
  for (const auto& out : o.outputs)
    for (ReadFile& r : out->read_files()) reads.push_back(std::move(r));
  check_output_paths(in, reads, files, dirs);
}

// Before any work: sections at any angle need a method that reads them,
// and a family of its own has no slice fields or sampled planes for the
// outputs made of them.
void check_method_reads_input(const Inputs& in, const ReconstructParams& params, const RunOptions& o) {
  const MethodSpec* m = find_method(params.method.name());
  const bool any_angle = std::any_of(in.jobs.begin(), in.jobs.end(), [](const Job& j) { return !j.sections.empty(); });
  if (any_angle && !(m && m->reads_sections))
    throw ParamError(option_name("--method") + " " + params.method.name() +
                     ": reads parallel slices; " + (in.format == InputFormat::Csl ? "a CSL file's" : "sections'") +
                     " planes at any angle need " +
                     option_given("--method", section_method_names()));
  if (!in.jobs.empty() && !in.jobs.front().sections.empty() && !(m && m->reads_sections))
    throw ParamError(option_name("--method") + " " + params.method.name() +
                     ": reads parallel slices; a volume annotated along several axes needs " +
                     option_given("--method", section_method_names()));
  if (!m || !m->reconstruct) return;
  const bool annotated = in.format == InputFormat::Volume && !in.jobs.front().sections.empty();
  for (const auto& out : o.outputs)
    if (annotated && out->option() == "--rtstruct")
      throw ParamError(option_name("--rtstruct") +
                       ": not with a volume annotated along several axes (RT contours are written on axial slices)");
  for (const auto& out : o.outputs)
    if (const std::string opt = out->option(); opt == "--volume" || opt == "--labelmap" || opt == "--dump-stages")
      throw ParamError(option_name(opt) + ": not with " + option_given("--method", params.method.name()) +
                       " (it has no slice fields or sampled planes to write)");
}

// Before any work: the outputs' own checks, the files they will write, the
// labels, and the input's footprint through the contour stage.
void check_run(const Inputs& in, const ReconstructParams& params, const RunOptions& o) {
  for (const auto& out : o.outputs)
    if (o.z_slab.count > 1 && out->option() != "-o")
      throw ParamError(option_name("--z-slab") + ": a slab is part of a surface; " + option_name(out->option()) +
                       " needs the whole (write it from the joined mesh)");
  for (const auto& out : o.outputs) {
    out->check_format(in.format);
    out->check(in, params);
  }
  check_planned_files(in, o);
  const SliceStack& st = in.first();
  check_budget(option_name("--max-memory"),
               "the contour stage of " + std::to_string(st.slices.size()) + " slices of " + std::to_string(st.width) +
                   "x" + std::to_string(st.height) + " px",
               input_bytes(in), o.budget.max_memory);
  // What the outputs hold and write whatever the objects (a label map on a reference grid).
  double fixed = 0;
  for (const auto& out : o.outputs) {
    const std::string what = option_name(out->option()) + " " + out->target();
    check_held_memory(option_name("--max-memory"), what, input_bytes(in) + out->memory_bytes(in), o.budget.max_memory);
    fixed += out->fixed_file_bytes(in);
    check_budget(option_name("--max-output"), what, fixed, o.budget.max_output);
  }
  check_labels(in, o.labels, option_name("--labels"));
  check_method_reads_input(in, params, o);
}

// Runs `write`, an output's work: its error names the flag (if given) and
// the final path of every file, never a hidden staged one.
template <class F>
void as_output(const OutputSet& files, const std::string& flag, F&& write) {
  auto named = [&](const char* what) {
    std::string m = files.final_names(what);
    const std::string opt = flag.empty() ? std::string() : option_name(flag);
    return opt.empty() || m.rfind(opt, 0) == 0 ? m : opt + " " + m;
  };
  try {
    write();
  } catch (const ParamError& e) {
    throw ParamError(named(e.what()));
  } catch (const InputError& e) {
    throw InputError("", named(e.what()));
  } catch (const Error& e) {
    throw Error(named(e.what()));
  }
}

// Object-level progress: per (job, label) the steps of its stages (contour,
// fit, planes, decimation), their totals from the stage itself or, before it
// starts, from the object's work estimate. Steps reported out of order
// (parallel slices) are dropped, so done only grows.
class ProgressTracker {
 public:
  explicit ProgressTracker(bool decimates) : decimates_(decimates) {}

  void estimate(std::size_t job, const WorkEstimate& e) {
    std::lock_guard lock(m_);
    Object& o = objects_[{job, e.label}];
    o.total[1] = std::max(o.total[1], long(e.slices));
    o.total[2] = std::max(o.total[2], long(e.planes));
    o.total[3] = std::max(o.total[3], decimates_ ? 1L : 0L);
  }

  /// Fills the object's done and total; false for a stale step.
  bool step(RunProgress& p) {
    const std::size_t s = p.stage == "contour" ? 0 : p.stage == "interpolate+mesh" ? 2 : p.stage == "decimate" ? 3 : 1;
    std::lock_guard lock(m_);
    Object& o = objects_[{p.job, p.label}];
    if (p.done < o.done[s] || (p.done == o.done[s] && o.seen[s])) return false;
    o.seen[s] = true;
    o.done[s] = p.done;
    o.total[s] = p.total;
    for (std::size_t k = 0; k < s; ++k) o.done[k] = o.total[k];  // earlier stages are over
    p.object_done = p.object_total = 0;
    for (std::size_t k = 0; k < kStages; ++k) p.object_done += o.done[k], p.object_total += o.total[k];
    return true;
  }

 private:
  static constexpr std::size_t kStages = 4;
  struct Object {
    std::array<long, kStages> done{}, total{};
    std::array<bool, kStages> seen{};
  };
  bool decimates_;
  std::mutex m_;
  std::map<std::pair<std::size_t, std::uint32_t>, Object> objects_;
};

}  // namespace

Rgb label_colour(std::size_t i) {
  const double h = std::fmod(0.13 + 0.618033988749895 * double(i), 1.0) * 6.0;
  const double x = 1.0 - std::abs(std::fmod(h, 2.0) - 1.0);
  double r = 0, g = 0, b = 0;
  switch (int(h)) {
    case 0: r = 1, g = x; break;
    case 1: r = x, g = 1; break;
    case 2: g = 1, b = x; break;
    case 3: g = x, b = 1; break;
    case 4: r = x, b = 1; break;
    default: r = 1, b = x; break;
  }
  auto c = [](double v) { return std::uint8_t(std::lround(40 + 215 * v)); };
  return {c(r), c(g), c(b)};
}

void check_outputs_format(const RunOptions& options, InputFormat format) {
  for (const auto& out : options.outputs) out->check_format(format);
}

void check_surfaces(const Inputs& in, const RunResult& r, bool allow_empty) {
  const std::string path = in.files.empty() ? "slices" : in.files.front();
  if (r.objects.empty())
    throw InputError(path, "nothing to reconstruct: no slice has an inside (a closed contour, or mask pixels)");
  if (allow_empty) return;
  for (const RunObject& ob : r.objects) {
    if (ob.object.triangle_count() > 0) continue;
    const std::string& roi = in.jobs[ob.job].name;
    throw InputError(path, (roi.empty() ? "" : "ROI '" + roi + "': ") +
                               (ob.object.label ? "label " + std::to_string(ob.object.label) : "the surface") +
                               " is empty (0 triangles): " + ob.object.empty_reason + " (" +
                               option_given("--allow-empty") + " writes it anyway)");
  }
}

std::vector<Vec3d> contour_vertices(const SliceStack& st) {
  std::vector<Vec3d> v;
  for (const Slice& s : st.slices)
    for (const Polygon& poly : s.polygons)
      for (const Vec2d& p : poly.points) v.emplace_back(p.x(), p.y(), s.z);
  return v;
}

namespace {

bool sees_objects_one_by_one(const ReconstructOptions& o) { return o.on_slice_fields || o.on_plane || o.on_sample; }

// What the run reads from a polygon job's final mesh besides its check: the
// RT ROIs' contour vertex distances (the error of the working grid isoloft
// chose for them: RT grid, triangle budget) and the volume table's clipped
// volumes. Beside the check when the method calls on_final, else after.
void read_final_mesh(const Inputs& in, std::size_t j, ObjectResult& ob) {
  const Job& job = in.jobs[j];
  if (ob.mesh.empty()) return;
  tbb::parallel_invoke(
      [&] {
        if (job.roi && !ob.contour_distance)
          ob.contour_distance = summarize_distances(point_mesh_distances(ob.mesh, contour_vertices(job.stack)));
      },
      [&] {
        if (ob.clipped_volumes.empty()) ob.clipped_volumes = clipped_volumes(in, job, ob);
      });
}

// Pixel work of a job, to start the largest first.
double job_work(const Job& job) {
  const SliceStack& st = job.stack;
  return double(st.slices.size()) * double(st.width) * double(st.height);
}

// reconstruct() on every job. Side by side when no job has a per-plane,
// per-sample or per-slice hook (those see objects one at a time): the
// largest first, at most one per worker thread, each job's own parallel
// loops isolated (a waiting thread does not start another job inside them),
// on_estimate called one at a time. The results are those of running the
// jobs in turn; the first error in job order is rethrown. Otherwise in turn.
std::vector<ReconstructResult> reconstruct_jobs(const Inputs& in, const ReconstructParams& params,
                                                const std::vector<std::uint32_t>& labels,
                                                const std::function<void(std::size_t, ReconstructOptions&)>& configure,
                                                const std::function<void(std::size_t)>& finished) {
  const std::size_t n = in.jobs.size();
  std::vector<ReconstructResult> results(n);
  std::vector<ReconstructOptions> options(n);
  bool one_by_one = n < 2;
  for (std::size_t j = 0; j < n; ++j) {
    options[j].labels = labels;
    if (configure) configure(j, options[j]);
    if (in.jobs[j].stack.has_polygons()) options[j].on_final = [&in, j](ObjectResult& ob) { read_final_mesh(in, j, ob); };
    one_by_one = one_by_one || sees_objects_one_by_one(options[j]);
  }
  auto run_one = [&](std::size_t j) {
    const Job& job = in.jobs[j];
    results[j] = reconstruct(MethodInput{job.stack, job.sections, job.section_label, job.partition.get()}, params, options[j]);
    if (finished) finished(j);
    if (in.jobs[j].stack.has_polygons())
      for (ObjectResult& ob : results[j].objects) read_final_mesh(in, j, ob);
  };
  if (one_by_one) {
    for (std::size_t j = 0; j < n; ++j) run_one(j);
    return results;
  }
  std::mutex estimates;
  for (ReconstructOptions& o : options)
    if (o.on_estimate)
      o.on_estimate = [&estimates, f = o.on_estimate](const WorkEstimate& e) {
        const std::lock_guard lock(estimates);
        f(e);
      };
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return job_work(in.jobs[a]) > job_work(in.jobs[b]); });
  std::vector<std::exception_ptr> errors(n);
  std::atomic<std::size_t> next{0};
  const std::size_t workers = std::min<std::size_t>(n, std::size_t(std::max(1, tbb::this_task_arena::max_concurrency())));
  tbb::parallel_for(std::size_t(0), workers, [&](std::size_t) {
    for (std::size_t i; (i = next++) < n;) {
      const std::size_t j = order[i];
      tbb::this_task_arena::isolate([&] {
        try {
          run_one(j);
        } catch (...) {
          errors[j] = std::current_exception();
        }
      });
    }
  });
  for (const auto& e : errors)
    if (e) std::rethrow_exception(e);
  return results;
}

}  // namespace

RunResult run_jobs(const Inputs& in, const ReconstructParams& params, const std::vector<std::uint32_t>& labels,
                   const std::function<void(std::size_t, ReconstructOptions&)>& configure,
                   const std::function<void(std::size_t)>& finished) {
  RunResult all;
  all.warnings = in.warnings;
  all.threads = int(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
  std::vector<ReconstructResult> results = reconstruct_jobs(in, params, labels, configure, finished);
  for (std::size_t j = 0; j < in.jobs.size(); ++j) {
    const Job& job = in.jobs[j];
    ReconstructResult& r = results[j];
    for (auto& w : r.warnings) all.warnings.push_back(job.name.empty() ? w : "ROI '" + job.name + "': " + w);
    all.times += r.times;
    for (auto& ob : r.objects) {
      all.objects.push_back({j, std::move(ob), job.color.value_or(label_colour(all.objects.size())), {}});
    }
  }
  return all;
}

RunResult run(const Inputs& in, const ReconstructParams& params, RunOptions& o) {
  const auto t_start = Clock::now();
  tbb::task_arena arena(o.threads > 0 ? o.threads : int(tbb::task_arena::automatic));
  arena.execute([&] { check_run(in, params, o); });  // its slice scan in the run's threads
  OutputSet files;
  const RunContext ctx{in, params, files};
  auto activity = [&](const std::string& what) {
    if (o.activity) o.activity(what);
  };
  // The output that writes each object once final, if the run may free the meshes.
  RunOutput* streamer = nullptr;
  if (o.free_meshes && std::none_of(o.outputs.begin(), o.outputs.end(), [](const auto& out) { return out->reads_meshes(); }))
    for (const auto& out : o.outputs)
      if (out->streams_objects(in)) streamer = out.get();
  // Streamed, a label partition's meshes wait in scratch files beside the
  // output (ReconstructOptions::scratch_dir) until each is written.
  std::string spill_dir;
  if (streamer) {
    spill_dir = std::filesystem::path(streamer->target()).parent_path().string();
    if (spill_dir.empty()) spill_dir = ".";
    files.create_directories(spill_dir);
  }
  // Per object, after its contour stage and before its fit: memory and files against the budget.
  const double in_bytes = input_bytes(in);
  // What the objects estimated so far hold at once: their meshes until written
  // (streamed, each is freed once final: only a partition's are held together)
  // and, for a label partition (every label's fields streamed in lockstep),
  // their fields too. 16,384 labels of 2x2 px: 1.2 GiB of fields together.
  const bool joint_fields = params.label_partition && in.labels();
  double held_bytes = 0;
  // A streamed partition's meshes are read back one per thread: the largest so far, that many times.
  double largest_mesh = 0;
  const double loaded_meshes = o.threads > 0 ? o.threads : double(tbb::this_task_arena::max_concurrency());
  // The files written so far count against --max-output together (every
  // object's meshes and volumes, and the label maps' once).
  double output_bytes = 0, output_memory = 0;
  for (const auto& out : o.outputs) output_bytes += out->fixed_file_bytes(in), output_memory += out->memory_bytes(in);
  // ROIs run side by side (run_jobs): the fields of the jobs in flight.
  std::vector<double> job_fields(in.jobs.size(), 0.0);
  std::mutex held_mutex;
  auto check_object = [&](const Job& job, const WorkEstimate& e) {
    const std::string what = object_text(in, job, e);
    check_budget(option_name("--max-memory"), what, in_bytes + e.field_bytes + e.mesh_bytes, o.budget.max_memory);
    {
      std::lock_guard lock(held_mutex);
      // Streamed, no mesh is held past its object (a partition's wait on disk).
      held_bytes += (streamer ? 0.0 : e.mesh_bytes) + (joint_fields ? e.field_bytes : 0.0);
      largest_mesh = std::max(largest_mesh, e.mesh_bytes);
      if (!joint_fields)  // streamed, the object's mesh is held only while it runs
        job_fields[&job - in.jobs.data()] =
            std::max(job_fields[&job - in.jobs.data()], e.field_bytes + (streamer ? e.mesh_bytes : 0.0));
      double in_flight = 0;
      for (const double b : job_fields) in_flight += b;
      check_budget(option_name("--max-memory"),
                   (joint_fields ? "the labels' fields and meshes held together up to "
                                 : "the meshes held and the fields of the jobs running up to ") +
                       what,
                   in_bytes + held_bytes + output_memory + (joint_fields ? 0.0 : in_flight) +
                       (streamer && joint_fields ? loaded_meshes * largest_mesh : 0.0),
                   o.budget.max_memory);
    }
    double bytes = 0;
    std::string note;
    for (const auto& out : o.outputs) bytes += out->file_bytes(in, e), note += out->budget_note();
    double total = 0;
    {
      std::lock_guard lock(held_mutex);
      total = output_bytes += bytes;
    }
    check_budget(option_name("--max-output"), what + note + (total > bytes ? " and the files before it" : ""), total,
                 o.budget.max_output);
    activity("reconstructing " + what);
  };

  std::vector<JobHooks> hooks(in.jobs.size());
  ProgressTracker tracker(params.decimate.max_error > 0);
  RunResult r;
  arena.execute([&] { as_output(files, "", [&] {
    r = run_jobs(in, params, o.labels, [&](std::size_t j, ReconstructOptions& ropt) {
      for (const auto& out : o.outputs) out->start_job(ctx, j, hooks[j]);
      hooks[j].apply(ropt);
      ropt.z_slab = o.z_slab;
      if (streamer) {
        ropt.on_object = [&, j](ObjectResult& ob) { as_output(files, streamer->option(), [&] { streamer->object_done(ctx, j, ob); }); };
        ropt.scratch_dir = spill_dir;
      }
      const Job& job = in.jobs[j];
      ropt.on_estimate = [&, j](const WorkEstimate& e) {
        check_object(in.jobs[j], e);
        tracker.estimate(j, e);
      };
      if (o.progress)
        ropt.progress = [&, j](std::uint32_t label, const std::string& stage, long done, long total) {
          RunProgress p{j, job.name, label, stage, done, total};
          if (tracker.step(p)) o.progress(p);
        };
    }, [&](std::size_t j) {
      const std::lock_guard lock(held_mutex);
      job_fields[j] = 0;  // its fields are freed
    });
  }); });
  r.threads = std::min(arena.max_concurrency(),
                       int(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism)));
  if (o.warn)
    for (const auto& w : r.warnings) o.warn(w);
  check_surfaces(in, r, o.allow_empty || o.z_slab.count > 1);

  auto t0 = Clock::now();
  const std::size_t warned = r.warnings.size();
  for (const auto& out : o.outputs) {
    activity("writing " + out->target());
    as_output(files, out->option(), [&] { out->finish(ctx, r); });
  }
  if (o.warn)  // the outputs' own (e.g. RT contours dropped under --rt-min-area)
    for (std::size_t i = warned; i < r.warnings.size(); ++i) o.warn(r.warnings[i]);
  const double write_seconds = seconds_since(t0);
  r.report = run_report(o.git, o.command, in, params, r,
                        {o.read_seconds, write_seconds, o.seconds_before + seconds_since(t_start)});
  if (!o.heap.empty()) r.report["heap"] = o.heap;
  for (const auto& out : o.outputs) out->report(r.report);
  if (!o.report_path.empty())
    as_output(files, "--report", [&] { write_text_atomic(files.stage(o.report_path), r.report.dump(2) + "\n"); });
  files.commit();
  return r;
}

namespace {
// One object's field3d solve; lengths in mm (`s` mm per working unit).
nlohmann::json field3d_report(const Field3dStats& f, double s) {
  return {{"grid_nodes", f.grid},
          {"solve_nodes", f.solve_nodes},
          {"samples", f.samples},
          {"iterations", f.iterations},
          {"finest_iterations", f.finest_iterations},
          {"multigrid_levels", f.multigrid_levels},
          {"relative_residual", f.relative_residual},
          {"sign_points", f.sign_points},
          {"sign_active", f.sign_active},
          {"sign_violated", f.sign_violated},
          {"sign_passes", f.sign_passes},
          {"conflicts", f.conflicts},
          {"largest_conflict_mm", f.largest_conflict * s},
          {"planes", f.planes},
          {"plane_mesh_to_drawn_max_mm", f.mesh_to_drawn * s},
          {"plane_drawn_to_mesh_max_mm", f.drawn_to_mesh * s},
          {"seconds", f.seconds}};
}
}  // namespace

nlohmann::json objects_report(const Inputs& in, const RunResult& r, Method method) {
  nlohmann::json objects = nlohmann::json::array();
  for (const auto& o : r.objects) {
    const ObjectResult& ob = o.object;
    const Job& job = in.jobs[o.job];
    const double s = job.stack.pixel_size;
    nlohmann::json j = {{"label", ob.label}, {"file", o.file}};
    if (!job.name.empty()) j["roi"] = job.name;
    if (ob.label && !in.label_name(ob.label).empty()) j["name"] = in.label_name(ob.label);
    j["vertices"] = ob.vertex_count();
    j["triangles"] = ob.triangle_count();
    j["triangles_before_decimation"] = ob.triangles_before_decimation;
    if (ob.contour_distance) j["contour_vertex_distance"] = ob.contour_distance->to_json(s);
    j["slices_with_contours"] = ob.slices_with_contours;
    j["closed"] = ob.check.closed;
    j["manifold"] = ob.check.manifold;
    j["oriented"] = ob.check.oriented;
    j["components"] = ob.check.components;
    j["euler_characteristic"] = ob.check.euler;
    j["volume"] = ob.check.volume * s * s * s;
    j["area"] = ob.check.area * s * s;
    j["box_px"] = {ob.box.x0, ob.box.y0, ob.box.x1, ob.box.y1};
    if (fits_curves(method))
      j["mpu"] = {{"points", ob.fit.points},
                  {"leaves", ob.fit.leaves},
                  {"leaves_over_tol", ob.fit.leaves_over_tol},
                  {"max_depth_reached", ob.fit.max_depth_reached},
                  {"max_local_error_px", ob.fit.max_local_error},
                  {"fallback_slices", ob.fit.fallback_slices},
                  {"sign_guarded_pixels", ob.fit.sign_guarded_pixels},
                  {"sign_guarded_slices", ob.fit.sign_guarded_slices}};
    if (ob.field3d) j["field3d"] = field3d_report(*ob.field3d, s);
    objects.push_back(std::move(j));
  }
  return objects;
}

nlohmann::json run_report(const std::string& git, const std::string& command, const Inputs& in,
                          const ReconstructParams& params, const RunResult& r, const RunSeconds& seconds) {
  const auto& t = r.times;
  return {{"isoloft", {{"version", ISOLOFT_VERSION}, {"git", git}}},
          {"command", command},
          {"input", input_report(in)},
          {"params", params_to_json(params)},
          {"threads", r.threads},
          {"timings_s",
           {{"read", seconds.read},
            {"contour", t.contour},
            {"mpu", t.mpu},
            {"dist", t.dist},
            {"filter", t.filter},
            {"interp", t.interp},
            {"mesh", t.mesh},
            {"decimate", t.decimate},
            {"write", seconds.write},
            {"total", seconds.total}}},
          {"peak_memory_mib", peak_memory_mib()},
          {"objects", objects_report(in, r, params.method)},
          {"volumes", volume_table_json(volume_table(in, r))},
          {"volume_files", nlohmann::json::array()},
          {"warnings", r.warnings}};
}

double peak_memory_mib() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_maxrss) / 1024.0;  // ru_maxrss is in KiB on Linux
}

}  // namespace isoloft
