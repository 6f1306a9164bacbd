// @file methods/params.h
// @brief The rows of ReconstructParams (params_table<ReconstructParams>: key,
// unit, doc, range, flag), JSON both ways, and each method's defaults (from
// its registration, methods/method.h).
#pragma once

#include <nlohmann/json.hpp>
#include <optional>

#include "isoloft/objects/params.h"

namespace isoloft {

template <>
const ParamTable<ReconstructParams>& params_table<ReconstructParams>();

/// True for the methods that fit curves (MethodSpec::fits_curves: isoloft, marker2006).
/// \throw ParamError for a method not registered.
bool fits_curves(const Method& m);

/// A method's parameters: ReconstructParams{} (the default method's:
/// the extremum-preserving z spline, slab end caps) with what the method's
/// spec changes (MethodSpec::defaults: marker2006 and levin take Hyman's z
/// spline and dome caps; docs/decisions.md: the isoloft method, end caps).
/// \throw ParamError for a method not registered.
ReconstructParams method_defaults(const Method& m);

/// Parameters as JSON and back; from_json applies the keys present to `base`.
/// \throw ParamError naming a bad key, type or value.
nlohmann::json params_to_json(const ReconstructParams&);
ReconstructParams params_from_json(const nlohmann::json&, const ReconstructParams& base);
/// The keys present applied to method_defaults() of j's "method" (or of
/// `method` if given, e.g. from a flag; else the default method's).
ReconstructParams params_from_json(const nlohmann::json& j, std::optional<Method> method = std::nullopt);


}  // namespace isoloft
