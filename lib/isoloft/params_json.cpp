// ReconstructParams <-> JSON. Each stage's fields are listed once (fields()
// below); defaults come from the structs themselves, so they are written
// exactly once, in the stage headers.
#include <nlohmann/json.hpp>
#include <type_traits>

#include "isoloft/core/error.h"
#include "isoloft/pipeline.h"

namespace isoloft {

using nlohmann::json;

namespace {

// ---- enum names ----
std::string name_of(OpenContourPolicy p) {
  switch (p) {
    case OpenContourPolicy::Repair: return "repair";
    case OpenContourPolicy::Error: return "error";
    case OpenContourPolicy::Ignore: return "ignore";
  }
  return "?";
}
std::string name_of(SplineKind k) { return to_string(k); }
std::string name_of(ExtendMethod m) {
  switch (m) {
    case ExtendMethod::FastMarching: return "fast-marching";
    case ExtendMethod::MarchingCorrectness: return "mcc";
    case ExtendMethod::FastSweeping: return "fast-sweeping";
  }
  return "?";
}
std::string name_of(ExtendUpdate u) { return u == ExtendUpdate::ClosestPoint ? "closest-point" : "eikonal"; }
std::string name_of(Method m) { return to_string(m); }
std::string name_of(InputKind k) { return to_string(k); }

void parse_enum(const std::string& s, OpenContourPolicy& out) {
  for (auto p : {OpenContourPolicy::Repair, OpenContourPolicy::Error, OpenContourPolicy::Ignore})
    if (s == name_of(p)) {
      out = p;
      return;
    }
  throw ParamError("unknown open-contour policy '" + s + "' (expected repair, error or ignore)");
}
void parse_enum(const std::string& s, SplineKind& out) { out = spline_kind_from_string(s); }
void parse_enum(const std::string& s, ExtendMethod& out) {
  for (auto m : {ExtendMethod::FastMarching, ExtendMethod::MarchingCorrectness, ExtendMethod::FastSweeping})
    if (s == name_of(m)) {
      out = m;
      return;
    }
  throw ParamError("unknown extension method '" + s + "' (expected mcc, fast-marching or fast-sweeping)");
}
void parse_enum(const std::string& s, ExtendUpdate& out) {
  if (s == "closest-point") out = ExtendUpdate::ClosestPoint;
  else if (s == "eikonal") out = ExtendUpdate::Eikonal;
  else throw ParamError("unknown extension update '" + s + "' (expected closest-point or eikonal)");
}
void parse_enum(const std::string& s, Method& out) { out = method_from_string(s); }
void parse_enum(const std::string& s, InputKind& out) { out = input_kind_from_string(s); }

// ---- the fields of each stage ----
template <class F> void fields(FillParams& p, F&& f) {
  f("max_gap", p.max_gap);
  f("open_contours", p.open_policy);
}
template <class F> void fields(InterpParams& p, F&& f) {
  f("spline", p.spline);
  f("cap_extent", p.cap_extent);
  f("cap_depth", p.cap_depth);
  f("z_step", p.z_step);
}
template <class F> void fields(MarchingCubesParams& p, F&& f) { f("iso", p.iso); }
template <class F> void fields(NormalsParams& p, F&& f) { f("sigma", p.sigma); }
template <class F> void fields(MpuParams& p, F&& f) {
  f("n_min", p.n_min);
  f("n_floor", p.n_floor);
  f("tol", p.tol);
  f("alpha", p.alpha);
  f("lambda", p.lambda);
  f("max_depth", p.max_depth);
  f("corner_angle", p.corner_angle);
  f("component_link", p.component_link);
}
template <class F> void fields(NarrowBandParams& p, F&& f) {
  f("band_width", p.band_width);
  f("refine_iterations", p.refine_iterations);
  f("segment_splits", p.segment_splits);
}
template <class F> void fields(ExtendParams& p, F&& f) {
  f("method", p.method);
  f("update", p.update);
  f("max_sweep_cycles", p.max_sweep_cycles);
}
template <class F> void fields(FilterParams& p, F&& f) {
  f("enabled", p.enabled);
  f("d_min", p.d_min);
  f("d_max", p.d_max);
  f("sigma_min", p.sigma_min);
  f("sigma_max", p.sigma_max);
}
template <class F> void fields(DecimateParams& p, F&& f) {
  f("max_error", p.max_error);
  f("max_normal_deviation_deg", p.max_normal_deviation_deg);
}

// ---- generic conversion ----
template <class T> void put(json& j, const char* key, const T& v) {
  if constexpr (std::is_enum_v<T>) j[key] = name_of(v);
  else j[key] = v;
}

template <class T> void take(const json& j, const std::string& path, T& v) {
  if constexpr (std::is_enum_v<T>) {
    if (!j.is_string()) throw ParamError(path + ": expected a string");
    parse_enum(j.get<std::string>(), v);
  } else if constexpr (std::is_same_v<T, bool>) {
    if (!j.is_boolean()) throw ParamError(path + ": expected true or false");
    v = j.get<bool>();
  } else if constexpr (std::is_integral_v<T>) {
    if (!j.is_number_integer()) throw ParamError(path + ": expected an integer");
    v = j.get<T>();
  } else {
    if (!j.is_number()) throw ParamError(path + ": expected a number");
    v = j.get<T>();
  }
}

template <class S> json stage_to_json(const S& s) {
  json j = json::object();
  fields(const_cast<S&>(s), [&](const char* key, const auto& v) { put(j, key, v); });
  return j;
}

template <class S> void stage_from_json(const json& j, const std::string& path, S& s) {
  if (!j.is_object()) throw ParamError(path + ": expected an object");
  std::vector<std::string> known;
  fields(s, [&](const char* key, auto& v) {
    known.emplace_back(key);
    if (j.contains(key)) take(j[key], path + "." + key, v);
  });
  for (const auto& [k, _] : j.items())
    if (std::find(known.begin(), known.end(), k) == known.end()) throw ParamError("unknown parameter '" + path + "." + k + "'");
}

}  // namespace

json params_to_json(const ReconstructParams& p) {
  return {{"method", name_of(p.method)},
          {"input", name_of(p.input)},
          {"binarize", p.binarize},
          {"crop_margin", p.crop_margin},
          {"mask_edge_offset", p.mask_edge_offset},
          {"sign_guard", p.sign_guard},
          {"polyline_spacing", p.polyline_spacing},
          {"polyline_raster_width", p.polyline_raster_width},
          {"fill", stage_to_json(p.fill)},
          {"normals", stage_to_json(p.normals)},
          {"mpu", stage_to_json(p.mpu)},
          {"band", stage_to_json(p.band)},
          {"extend", stage_to_json(p.extend)},
          {"filter", stage_to_json(p.filter)},
          {"interp", stage_to_json(p.interp)},
          {"mc", stage_to_json(p.mc)},
          {"decimate", stage_to_json(p.decimate)}};
}

ReconstructParams params_from_json(const json& j, const ReconstructParams& base) {
  ReconstructParams p = base;
  if (!j.is_object()) throw ParamError("parameters: expected a JSON object");
  for (const auto& [k, v] : j.items()) {
    if (k == "method") take(v, k, p.method);
    else if (k == "input") take(v, k, p.input);
    else if (k == "binarize") take(v, k, p.binarize);
    else if (k == "crop_margin") take(v, k, p.crop_margin);
    else if (k == "mask_edge_offset") take(v, k, p.mask_edge_offset);
    else if (k == "sign_guard") take(v, k, p.sign_guard);
    else if (k == "polyline_spacing") take(v, k, p.polyline_spacing);
    else if (k == "polyline_raster_width") take(v, k, p.polyline_raster_width);
    else if (k == "fill") stage_from_json(v, k, p.fill);
    else if (k == "normals") stage_from_json(v, k, p.normals);
    else if (k == "mpu") stage_from_json(v, k, p.mpu);
    else if (k == "band") stage_from_json(v, k, p.band);
    else if (k == "extend") stage_from_json(v, k, p.extend);
    else if (k == "filter") stage_from_json(v, k, p.filter);
    else if (k == "interp") stage_from_json(v, k, p.interp);
    else if (k == "mc") stage_from_json(v, k, p.mc);
    else if (k == "decimate") stage_from_json(v, k, p.decimate);
    else throw ParamError("unknown parameter '" + k + "'");
  }
  return p;
}

}  // namespace isoloft
