// @file python/isoloft_module.cpp
// @brief isoloft._isoloft: the library on numpy arrays (pybind11). The Python
// API (argument defaults, paths vs arrays) is isoloft/__init__.py; this file
// binds the classes and functions and translates isoloft's errors. Arrays to
// slice stacks: module_inputs.cpp; runs and results: module_run.cpp.
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <string>

#include "isoloft/core/error.h"
#include "isoloft/core/option_names.h"
#include "isoloft/core/params.h"
#include "isoloft/core/sanitize.h"
#include "isoloft/run/manifest.h"
#include "isoloft/synth/synth.h"
#include "python/module.h"

namespace py = pybind11;
using namespace isoloft;
using namespace isoloft::python;

namespace {

PyObject* g_error = nullptr;        // isoloft.Error
PyObject* g_input_error = nullptr;  // isoloft.InputError (also a ValueError)
PyObject* g_param_error = nullptr;  // isoloft.ParamError (also a ValueError)

// A batch's cases as the dicts isoloft.cohort runs: input, name, options and,
// for a row that cannot run, error.
py::list cases_to_python(const std::vector<ManifestCase>& cases) {
  py::list out;
  for (const ManifestCase& c : cases) {
    py::dict d;
    d["input"] = c.input, d["name"] = c.name, d["options"] = c.options;
    if (!c.error.empty()) d["error"] = c.error;
    out.append(d);
  }
  return out;
}

PyObject* new_exception(py::module_& m, const char* name, PyObject* bases, const char* doc) {
  PyObject* e = PyErr_NewExceptionWithDoc((std::string("isoloft.") + name).c_str(), doc, bases, nullptr);
  if (!e) throw py::error_already_set();
  m.add_object(name, py::handle(e));
  return e;
}

}  // namespace

PYBIND11_MODULE(_isoloft, m) {
  m.doc() = "isoloft: closed surfaces from parallel planar contours (Marker et al. 2006); see the isoloft package";
  m.attr("__version__") = ISOLOFT_VERSION;
  m.attr("git") = ISOLOFT_GIT;
  m.attr("cli_path") = ISOLOFT_CLI_PATH;  // the CLI built with this module (isoloft.cli prefers a bundled one)
  // Errors name Python keywords (z_spacing, input='labels'), not the CLI's flags.
  set_option_style(OptionStyle::Keywords);

  g_error = new_exception(m, "Error", PyExc_Exception, "Base of all isoloft errors.");
  g_input_error = new_exception(m, "InputError", py::make_tuple(py::handle(g_error), py::handle(PyExc_ValueError)).release().ptr(),
                                "Bad input data: an unreadable, corrupt or inconsistent file or array (names it).");
  g_param_error = new_exception(m, "ParamError", py::make_tuple(py::handle(g_error), py::handle(PyExc_ValueError)).release().ptr(),
                                "A parameter or option outside its domain (names it).");
  // Messages carry names (ROIs, files) as read: escaped as the CLI prints
  // them (core/sanitize.h), so no control byte reaches a traceback raw.
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const isoloft::InputError& e) {
      PyErr_SetString(g_input_error, terminal_text(e.what()).c_str());
    } catch (const isoloft::ParamError& e) {
      PyErr_SetString(g_param_error, terminal_text(e.what()).c_str());
    } catch (const isoloft::Error& e) {
      PyErr_SetString(g_error, terminal_text(e.what()).c_str());
    } catch (const nlohmann::json::exception& e) {
      PyErr_SetString(g_param_error, terminal_text(e.what()).c_str());
    }
  });

  py::class_<PyInput, std::shared_ptr<PyInput>>(m, "Input", "Slice stacks read by isoloft.read() or made by isoloft.synth()")
      .def_property_readonly("format", [](const PyInput& i) { return to_string(i.in->format); })
      .def_property_readonly("files", [](const PyInput& i) { return i.in->files; })
      .def_property_readonly("kind", [](const PyInput& i) { return to_string(i.in->jobs.front().stack.kind); })
      .def_property_readonly("names", [](const PyInput& i) {
        std::vector<std::string> n;
        for (const auto& j : i.in->jobs) n.push_back(j.name);
        return n;
      }, "one per stack: the ROI name (RT Structure Sets), else ''")
      .def_property_readonly("slices", [](const PyInput& i) { return stack_images(i.in->jobs.front().stack); },
                             "(n, h, w) raw slice images of the first stack (None for polygons)")
      .def_property_readonly("polygons", [](const PyInput& i) { return stack_polygons(i.in->jobs.front().stack); },
                             "per slice, a list of (k, 2) x, y arrays (polygon inputs)")
      .def_property_readonly("slice_z", [](const PyInput& i) {
        std::vector<double> z;
        for (const auto& s : i.in->jobs.front().stack.slices) z.push_back(s.z);
        return py::array(py::cast(z));
      }, "z of every slice, working pixels")
      .def_property_readonly("pixel_size", [](const PyInput& i) { return i.in->jobs.front().stack.pixel_size; })
      .def_property_readonly("shape", [](const PyInput& i) {
        const auto& s = i.in->jobs.front().stack;
        return py::make_tuple(s.slices.size(), s.height, s.width);
      })
      .def_property_readonly("space", [](const PyInput& i) -> py::object {
        if (!i.in->jobs.front().stack.patient) return py::none();
        return py::str(i.in->ras ? "RAS" : "LPS");
      })
      .def_property_readonly("patient_axes", [](const PyInput& i) -> py::object {
        const auto& p = i.in->jobs.front().stack.patient;
        if (!p) return py::none();
        py::array_t<double> a({3, 3});
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) a.mutable_at(r, c) = p->axes(r, c);
        return a;
      }, "columns: LPS mm per working pixel along x, y, z (None without a patient frame)")
      .def_property_readonly("patient_origin", [](const PyInput& i) -> py::object {
        const auto& p = i.in->jobs.front().stack.patient;
        if (!p) return py::none();
        return py::array(py::cast(std::vector<double>{p->origin.x(), p->origin.y(), p->origin.z()}));
      })
      .def_property_readonly("annotated_slices", [](const PyInput& i) -> py::object {
        if (!i.in->slicing) return py::none();
        return py::cast(i.in->slicing->annotated);
      }, "volumes: voxel index of every slice along the annotated axis")
      .def_property_readonly("warnings", [](const PyInput& i) { return i.in->warnings; })
      .def_property_readonly("truth", [](const PyInput& i) -> py::object {
        return i.truth.is_null() ? py::object(py::none()) : to_python(i.truth);
      }, "synth(): the analytic shape and stack (as shape.json)")
      .def("__len__", [](const PyInput& i) { return i.in->jobs.front().stack.slices.size(); })
      .def("__repr__", [](const PyInput& i) {
        const auto& s = i.in->jobs.front().stack;
        return "<isoloft.Input " + to_string(i.in->format) + " " + to_string(s.kind) + ", " +
               std::to_string(i.in->jobs.size()) + " stack(s), " + std::to_string(s.slices.size()) + " slices of " +
               std::to_string(s.width) + "x" + std::to_string(s.height) + ">";
      });

  py::class_<PyObjectResult, std::shared_ptr<PyObjectResult>>(m, "Object", "One reconstructed closed surface")
      .def_property_readonly("label", [](const PyObjectResult& o) { return o.object().object.label; })
      .def_property_readonly("roi", [](const PyObjectResult& o) -> py::object {
        const std::string& n = o.data->in->jobs[o.object().job].name;
        return n.empty() ? py::object(py::none()) : py::str(n);
      })
      .def_property_readonly("colour", [](const PyObjectResult& o) {
        const Rgb c = o.object().colour;
        return py::make_tuple(c.r, c.g, c.b);
      })
      .def_readonly("vertices", &PyObjectResult::vertices,
                    "(N, 3) float64, read-only: patient mm (LPS/RAS) for volumes and RT Structure Sets, else pixels * pixel_size")
      .def_readonly("faces", &PyObjectResult::faces, "(M, 3) int32, read-only view of the C++ triangles (counter-clockwise from outside)")
      .def_property_readonly("report", [](const PyObjectResult& o) { return to_python(o.data->report["objects"][o.index]); })
      .def("save", [](const PyObjectResult& o, const py::object& path, bool ascii) {
        MeshWriteOptions mo = o.data->mesh_options;
        mo.ascii = ascii;
        const std::string p = checked_path(path, "path");
        py::gil_scoped_release release;
        save_run_meshes(p, "--path", *o.data->in, o.data->run, mo, o.data->reads, o.index);
      }, py::arg("path"), py::arg("ascii") = false,
         "writes this mesh as the CLI would (.ply .obj .stl .off .vtp .vtk), with reconstruct()'s output checks")
      .def("__repr__", [](const PyObjectResult& o) {
        const auto& m = o.object().object.mesh;
        return "<isoloft.Object label " + std::to_string(o.object().object.label) + ": " +
               std::to_string(m.vertices.size()) + " vertices, " + std::to_string(m.triangles.size()) + " faces>";
      });

  py::class_<PyProgress>(m, "Progress", "One step of a reconstruct() run, given to its progress callback")
      .def_readonly("label", &PyProgress::label, "the object's label (0: the only object, or a label input's shared scan)")
      .def_property_readonly("roi", [](const PyProgress& p) -> py::object {
        return p.roi.empty() ? py::object(py::none()) : py::str(p.roi);
      }, "the ROI's name (RT Structure Sets), else None")
      .def_readonly("stage", &PyProgress::stage, "contour, mpu+distance, interpolate+mesh or decimate")
      .def_readonly("done", &PyProgress::done, "the object's steps done: only grows")
      .def_readonly("total", &PyProgress::total, "the object's steps known so far (all of them once its fit starts)")
      .def_readonly("stage_done", &PyProgress::stage_done)
      .def_readonly("stage_total", &PyProgress::stage_total)
      .def("__repr__", [](const PyProgress& p) {
        return "<isoloft.Progress " + (p.roi.empty() ? "label " + std::to_string(p.label) : "ROI '" + p.roi + "'") + " " +
               p.stage + " " + std::to_string(p.done) + "/" + std::to_string(p.total) + ">";
      });

  py::class_<PyResult>(m, "Result", "What isoloft.reconstruct() returns")
      .def_readonly("objects", &PyResult::objects)
      .def_property_readonly("report", [](const PyResult& r) { return to_python(r.data->report); },
                             "the CLI's --report as a dict")
      .def_property_readonly("warnings", [](const PyResult& r) { return r.data->run.warnings; })
      .def("save", [](PyResult& r, const py::object& path, bool ascii) {
        const std::string p = checked_path(path, "path");
        MeshWriteOptions mo = r.data->mesh_options;
        mo.ascii = ascii;
        std::vector<std::string> files;
        {
          py::gil_scoped_release release;
          files = save_run_meshes(p, "--path", *r.data->in, r.data->run, mo, r.data->reads);
        }
        r.data->report["objects"] = objects_report(*r.data->in, r.data->run, r.data->method);
        return files;
      }, py::arg("path"), py::arg("ascii") = false,
         "writes the meshes as `isoloft reconstruct -o path` does, all together or none, with its output checks; "
         "returns the files written")
      .def("__len__", [](const PyResult& r) { return r.data->run.objects.size(); })
      .def("__getitem__", [](const PyResult& r, py::ssize_t i) { return r.objects.attr("__getitem__")(i); });

  m.def("_from_arrays", &from_arrays, py::arg("slices"), py::arg("kind"), py::arg("z_spacing"), py::arg("slice_z"),
        py::arg("pixel_size"), py::arg("image_shape"), py::arg("binarize"));
  m.def("_from_volume", &from_volume, py::arg("data"), py::arg("spacing"), py::arg("origin"), py::arg("direction"),
        py::arg("integer"), py::arg("name"), py::arg("kind"), py::arg("axis"), py::arg("space"),
        py::arg("label_names") = "");
  m.def("_from_sections", &from_sections, py::arg("sections"));
  m.attr("_DEFAULT_MAX_FILES") = kDefaultMaxFiles;
  m.def("_read", &read_input, py::arg("paths"), py::arg("kind"), py::arg("z_spacing"), py::arg("slice_z"),
        py::arg("pixel_size"), py::arg("axis"), py::arg("rois"), py::arg("voxel_size"), py::arg("space"),
        py::arg("max_memory"), py::arg("allow_external_data"), py::arg("label_names") = "", py::arg("method") = "");
  m.def("_reconstruct", [](const PyInput& input, const py::dict& params, const std::vector<std::uint32_t>& labels,
                           std::optional<int> threads, const py::object& progress, bool allow_empty,
                           const std::string& volume, const std::string& labelmap, const std::string& dump_stages,
                           const std::string& rtstruct, double rt_point_spacing, double rt_min_area,
                           const std::string& rt_contours, const std::string& volumes, const std::string& report,
                           const std::string& max_memory, const std::string& max_output, long max_files,
                           const std::string& reference) {
          return run(input, params, labels, threads, progress, allow_empty,
                     {volume, labelmap, dump_stages, rtstruct, volumes, report, reference,
                      RtContourParams{rt_point_spacing, rt_min_area}, rt_contours},
                     max_memory, max_output, max_files);
        }, py::arg("input"), py::arg("params"), py::arg("labels"), py::arg("threads"), py::arg("progress"),
        py::arg("allow_empty"), py::arg("volume"), py::arg("labelmap"), py::arg("dump_stages"), py::arg("rtstruct"),
        py::arg("rt_point_spacing"), py::arg("rt_min_area"), py::arg("rt_contours"), py::arg("volumes"), py::arg("report"), py::arg("max_memory"), py::arg("max_output"), py::arg("max_files"),
        py::arg("reference"));
  m.def("_read_manifest", [](const py::object& path) { return cases_to_python(read_manifest(checked_path(path, "manifest"))); },
        py::arg("path"), "a batch manifest's cases, checked (isoloft/run/manifest.h)");
  m.def("_check_manifest_rows", [](const py::list& rows, const std::string& base, const std::string& where,
                                   std::size_t first) {
          std::vector<ManifestRow> checked;
          for (const py::handle& h : rows) {
            const py::dict d = py::reinterpret_borrow<py::dict>(h);
            ManifestRow r;
            r.row = first + checked.size();
            auto text = [&](const char* key) {
              return d.contains(key) && !d[key].is_none() ? std::string(py::str(d[key])) : std::string();
            };
            r.input = text("input"), r.name = text("name");
            if (d.contains("options") && !d["options"].is_none() && !py::isinstance<py::str>(d["options"])) {
              std::vector<std::string> words;
              for (const py::handle& w : d["options"]) words.push_back(py::str(w));
              r.option_words = std::move(words);
            } else {
              r.options = text("options");
            }
            checked.push_back(std::move(r));
          }
          return cases_to_python(check_manifest_rows(checked, base, where));
        }, py::arg("rows"), py::arg("base"), py::arg("where"), py::arg("first"),
        "rows given as dicts (input, name, options: text or a list of words) checked as a manifest's");
  m.def("_terminal_text", [](const std::string& s) { return terminal_text(s); }, py::arg("text"),
        "text with control bytes escaped, as the CLI prints names (core/sanitize.h)");
  m.def("_synth", &synth, py::arg("shape"), py::arg("size"), py::arg("z_spacing"), py::arg("kind"));
  m.def("_evaluate", &evaluate, py::arg("mesh"), py::arg("truth"), py::arg("pixel_size"));
  m.def("shapes", &shape_names, "the analytic shapes isoloft.synth() makes");
  m.def("default_params", [] { return to_python(params_to_json(ReconstructParams{})); },
        "every reconstruction parameter with its default (as `isoloft reconstruct --print-params`)");
  m.def("describe_params", [] { return commented_json(params_table<ReconstructParams>(), ReconstructParams{}); },
        "the parameters as commented JSON, each with its unit, range and doc");
}

