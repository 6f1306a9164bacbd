// @file core/params.h
// @brief Parameter tables: one per Params struct, one row per field.
//
// A row names a field (JSON key), its unit, a one-line doc with the paper
// section, its valid range and, for user-facing fields, its CLI flag; JSON in
// and out, validation, `isoloft reconstruct --print-params` and the CLI flags
// all read it. Every value crosses as JSON, so every way in takes the same
// checks on the real type (no wrap of 2^32 + 1, no NaN). Enums have one name
// table each (enum_names(), found by ADL, beside the enum).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "isoloft/core/error.h"

namespace isoloft {

// ---------------------------------------------------------------- enums

/// One value of an enum and its name (lower case, as in JSON and on the CLI).
template <class E>
struct EnumName {
  E value;
  const char* name;
};

/// An enum with a name table: `enum_names(E{})` (found by ADL) returns it.
template <class E>
concept NamedEnum = std::is_enum_v<E> && requires(E e) {
  { enum_names(e) } -> std::convertible_to<std::span<const EnumName<E>>>;
};

/// The names of E's values in table order.
template <NamedEnum E>
std::vector<std::string> enum_choices() {
  std::vector<std::string> out;
  for (const auto& n : enum_names(E{})) out.emplace_back(n.name);
  return out;
}

/// The name of `value` (from its enum's table).
template <NamedEnum E>
std::string to_string(E value) {
  for (const auto& n : enum_names(value))
    if (n.value == value) return n.name;
  return "?";
}

/// \throw ParamError "<what>: unknown value 'x' (expected a, b or c)".
[[noreturn]] void throw_unknown_choice(const std::string& what, const std::string& name,
                                       const std::vector<std::string>& choices);

/// The value named `name`.
/// \throw ParamError "<what>: unknown value 'x' (expected a, b or c)".
template <NamedEnum E>
E enum_from_string(const std::string& name, const std::string& what) {
  for (const auto& n : enum_names(E{}))
    if (name == n.name) return n.value;
  throw_unknown_choice(what, name, enum_choices<E>());
}

// ---------------------------------------------------------------- ranges

/// Valid values of a number: lo .. hi, each end closed or open; NaN never.
struct Range {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_open = false, hi_open = false;

  [[nodiscard]] bool contains(double v) const {
    if (std::isnan(v)) return false;
    return (lo_open ? v > lo : v >= lo) && (hi_open ? v < hi : v <= hi);
  }
  /// E.g. ">= 1", "> 0", "[0, 90)", "any".
  [[nodiscard]] std::string text() const;
};

inline Range at_least(double lo) { return {lo, std::numeric_limits<double>::infinity(), false, false}; }
inline Range above(double lo) { return {lo, std::numeric_limits<double>::infinity(), true, false}; }
inline Range between(double lo, double hi) { return {lo, hi, false, false}; }
inline Range open_between(double lo, double hi) { return {lo, hi, true, true}; }
/// Finite numbers only (every number field is at least this).
inline Range finite() { return {-std::numeric_limits<double>::max(), std::numeric_limits<double>::max(), false, false}; }

// ---------------------------------------------------------------- rows

enum class ParamType { Bool, Int, Number, Enum };

/// One field of a Params struct S. Built by field() / nest(); read by the
/// table's users through the members below.
template <class S>
struct ParamRow {
  std::string key;    ///< JSON key; nested rows carry dotted paths ("mpu.n_min")
  std::string unit;   ///< "px", "points", "deg", "spacings", ... ("" for none)
  std::string doc;    ///< one line, with the paper section
  ParamType type = ParamType::Number;
  std::vector<std::string> choices;  ///< Enum: the value names
  Range range;                       ///< Int, Number
  std::string flag;                  ///< CLI flag ("--n-min"); "" = only via a params file
  bool flag_sets = true;             ///< Bool with a flag: the value the bare flag sets
  std::function<nlohmann::json(const S&)> get;
  /// Sets the field, type and range checked; throws ParamError naming `key`
  /// (the caller passes the row's full key).
  std::function<void(S&, const nlohmann::json&, const std::string& key)> set;

  /// The row with a CLI flag.
  ParamRow&& cli(std::string name, bool sets = true) && {
    flag = std::move(name);
    flag_sets = sets;
    return std::move(*this);
  }
};

namespace detail {

std::string json_type_name(const nlohmann::json& j);
[[noreturn]] void throw_bad_value(const std::string& key, const std::string& expected, const nlohmann::json& got);
[[noreturn]] void throw_out_of_range(const std::string& key, const Range& r, const nlohmann::json& got);

template <class T>
T checked_value(const nlohmann::json& j, const std::string& key, const Range& range) {
  if constexpr (std::is_same_v<T, bool>) {
    if (!j.is_boolean()) throw_bad_value(key, "true or false", j);
    return j.get<bool>();
  } else if constexpr (NamedEnum<T>) {
    if (!j.is_string()) throw_bad_value(key, "a string", j);
    return enum_from_string<T>(j.get<std::string>(), key);
  } else if constexpr (std::is_integral_v<T>) {
    // Range-check as a wide integer first: no wrap of 2^32 + 1 into 1.
    if (!j.is_number_integer()) throw_bad_value(key, "an integer", j);
    const bool neg = j.is_number_unsigned() ? false : j.get<std::int64_t>() < 0;
    const double v = neg ? double(j.get<std::int64_t>()) : double(j.get<std::uint64_t>());
    if (!range.contains(v) || v < double(std::numeric_limits<T>::min()) || v > double(std::numeric_limits<T>::max()))
      throw_out_of_range(key, range, j);
    return static_cast<T>(neg ? j.get<std::int64_t>() : std::int64_t(j.get<std::uint64_t>()));
  } else {
    if (!j.is_number()) throw_bad_value(key, "a number", j);
    const double v = j.get<double>();
    if (!range.contains(v)) throw_out_of_range(key, range, j);
    return static_cast<T>(v);
  }
}

template <class T>
constexpr ParamType param_type() {
  if constexpr (std::is_same_v<T, bool>) return ParamType::Bool;
  else if constexpr (std::is_enum_v<T>) return ParamType::Enum;
  else if constexpr (std::is_integral_v<T>) return ParamType::Int;
  else return ParamType::Number;
}

}  // namespace detail

/// A row for member `m` of S. Numbers are checked against `range` (and are
/// always finite); enums against their name table.
template <class S, class T>
ParamRow<S> field(std::string key, T S::*m, std::string unit, std::string doc, Range range = finite()) {
  static_assert(std::is_same_v<T, bool> || std::is_arithmetic_v<T> || NamedEnum<T>, "field(): unsupported member type");
  ParamRow<S> r;
  r.key = std::move(key);
  r.unit = std::move(unit);
  r.doc = std::move(doc);
  r.type = detail::param_type<T>();
  if constexpr (NamedEnum<T>) r.choices = enum_choices<T>();
  if constexpr (std::is_floating_point_v<T>) {
    r.range = {std::max(range.lo, finite().lo), std::min(range.hi, finite().hi), range.lo_open, range.hi_open};
  } else {
    r.range = range;
  }
  r.get = [m](const S& s) -> nlohmann::json {
    if constexpr (NamedEnum<T>) return to_string(s.*m);
    else return s.*m;
  };
  r.set = [m, range = r.range](S& s, const nlohmann::json& j, const std::string& key) {
    s.*m = detail::checked_value<T>(j, key, range);
  };
  return r;
}

/// A row for member `m` holding one of `choices` by name (a registry's names,
/// e.g. the methods): T is std::string or has name() and T(std::string).
template <class S, class T>
ParamRow<S> name_field(std::string key, T S::*m, std::string doc, std::vector<std::string> choices) {
  ParamRow<S> r;
  r.key = std::move(key);
  r.doc = std::move(doc);
  r.type = ParamType::Enum;
  r.choices = std::move(choices);
  r.get = [m](const S& s) -> nlohmann::json {
    if constexpr (std::is_same_v<T, std::string>) return s.*m;
    else return (s.*m).name();
  };
  r.set = [m, choices = r.choices](S& s, const nlohmann::json& j, const std::string& key) {
    if (!j.is_string()) detail::throw_bad_value(key, "a string", j);
    const std::string name = j.get<std::string>();
    if (std::find(choices.begin(), choices.end(), name) == choices.end()) throw_unknown_choice(key, name, choices);
    s.*m = T(name);
  };
  return r;
}

/// A Params struct's table: its rows, plus checks that relate several fields
/// (e.g. d_min < d_max).
template <class S>
class ParamTable {
 public:
  using Rows = std::vector<ParamRow<S>>;
  /// A cross-field check; throws ParamError whose message starts with
  /// `prefix` (the struct's path, e.g. "filter.") and a field name.
  using Check = std::function<void(const S&, const std::string& prefix)>;

  ParamTable(Rows rows, std::vector<Check> checks = {}) : rows_(std::move(rows)), checks_(std::move(checks)) {}

  [[nodiscard]] const Rows& rows() const { return rows_; }
  /// The row with this (dotted) key, or nullptr.
  [[nodiscard]] const ParamRow<S>* find(const std::string& key) const {
    for (const auto& r : rows_)
      if (r.key == key) return &r;
    return nullptr;
  }

  /// Every field as nested JSON (dotted keys become objects).
  [[nodiscard]] nlohmann::json to_json(const S& s) const {
    nlohmann::json j = nlohmann::json::object();
    for (const auto& r : rows_) j[nlohmann::json::json_pointer(pointer(r.key))] = r.get(s);
    return j;
  }

  /// `base` with the keys present in `j` applied (nested objects or dotted
  /// keys), then validate()d.
  /// \throw ParamError naming an unknown key, a wrong type or a value out of range.
  [[nodiscard]] S from_json(const nlohmann::json& j, S base = {}) const {
    apply(j, "", base);
    validate(base);
    return base;
  }

  /// Applies one value by (dotted) key, type and range checked.
  void set(S& s, const std::string& key, const nlohmann::json& value) const {
    const ParamRow<S>* r = find(key);
    if (!r) throw ParamError("unknown parameter '" + key + "'");
    r->set(s, value, r->key);
  }

  /// Every row's range (a value set in code may be anything) and the table's
  /// cross-field checks. \throw ParamError naming the key.
  void validate(const S& s) const {
    S copy = s;
    for (const auto& r : rows_) r.set(copy, r.get(s), r.key);
    for (const auto& c : checks_) c(s, "");
  }

  /// Appends the rows and checks of `sub`, the table of member `m`, under
  /// `prefix.` (used to build a table of tables, e.g. ReconstructParams).
  template <class Sub>
  static void nest(Rows& rows, std::vector<Check>& checks, const std::string& prefix, Sub S::*m,
                   const ParamTable<Sub>& sub) {
    for (const auto& r : sub.rows()) {
      ParamRow<S> n;
      n.key = prefix + "." + r.key;
      n.unit = r.unit;
      n.doc = r.doc;
      n.type = r.type;
      n.choices = r.choices;
      n.range = r.range;
      n.flag = r.flag;
      n.flag_sets = r.flag_sets;
      n.get = [m, get = r.get](const S& s) { return get(s.*m); };
      n.set = [m, set = r.set](S& s, const nlohmann::json& j, const std::string& key) { set(s.*m, j, key); };
      rows.push_back(std::move(n));
    }
    for (const auto& c : sub.checks_)
      checks.push_back([m, c, prefix](const S& s, const std::string& outer) { c(s.*m, outer + prefix + "."); });
  }

 private:
  template <class>
  friend class ParamTable;

  static std::string pointer(const std::string& key) {
    std::string p = "/" + key;
    for (char& c : p)
      if (c == '.') c = '/';
    return p;
  }
  void apply(const nlohmann::json& j, const std::string& path, S& s) const {
    if (!j.is_object()) throw ParamError((path.empty() ? std::string("parameters") : path) + ": expected an object");
    for (const auto& [k, v] : j.items()) {
      const std::string key = path.empty() ? k : path + "." + k;
      if (const ParamRow<S>* r = find(key)) {
        r->set(s, v, r->key);
      } else if (v.is_object() && has_prefix(key + ".")) {
        apply(v, key, s);
      } else {
        throw ParamError("unknown parameter '" + key + "'");
      }
    }
  }
  [[nodiscard]] bool has_prefix(const std::string& p) const {
    for (const auto& r : rows_)
      if (r.key.rfind(p, 0) == 0) return true;
    return false;
  }

  Rows rows_;
  std::vector<Check> checks_;
};

/// The table of S: one specialisation per Params struct, inline below the
/// struct (ReconstructParams: methods/params.cpp).
template <class S>
const ParamTable<S>& params_table();

/// A value for `row` from command-line text: "true"/"false" for bools,
/// integers and numbers in C syntax ("nan" and "inf" parse, and are then
/// rejected by the range), enum names as they are.
/// \throw ParamError naming `what` (e.g. the flag) if the text is not of the row's type.
nlohmann::json parse_value(ParamType type, const std::string& text, const std::string& what);

/// Unit, valid values and doc of a row in one line, e.g.
/// "points, >= 1: N_min, points per local fit (paper 2.1)".
std::string describe_row(const std::string& unit, ParamType type, const Range& range,
                         const std::vector<std::string>& choices, const std::string& doc);
template <class S>
std::string describe(const ParamRow<S>& r) {
  return describe_row(r.unit, r.type, r.range, r.choices, r.doc);
}

/// `values` (nested JSON objects) printed as JSON with a `// comment(key)`
/// line above every leaf (dotted key), e.g. --print-params; readable back by
/// nlohmann::json::parse(..., ignore_comments = true).
std::string commented_json(const nlohmann::json& values, const std::function<std::string(const std::string&)>& comment);

/// The table's values of `s`, each with its row described (describe()).
template <class S>
std::string commented_json(const ParamTable<S>& table, const S& s) {
  return commented_json(table.to_json(s), [&](const std::string& key) {
    const ParamRow<S>* r = table.find(key);
    return r ? describe(*r) : std::string();
  });
}

}  // namespace isoloft
