// The registered methods and z schemes: one line each (methods/method.h).
#include <algorithm>

#include "isoloft/core/error.h"
#include "isoloft/methods/method.h"
#include "isoloft/objects/params.h"

namespace isoloft {

// Each file's spec (methods/<family>/<name>.cpp).
MethodSpec isoloft_method();
MethodSpec marker2006_method();
MethodSpec levin_method();
MethodSpec field3d_method();
ZSchemeSpec columns_z_scheme();
ZSchemeSpec track_z_scheme();

const std::vector<MethodSpec>& methods() {
  static const std::vector<MethodSpec> all{
      isoloft_method(),
      marker2006_method(),
      levin_method(),
      field3d_method(),
  };
  return all;
}

const std::vector<ZSchemeSpec>& z_schemes() {
  static const std::vector<ZSchemeSpec> all{
      columns_z_scheme(),
      track_z_scheme(),
  };
  return all;
}

namespace {

template <class Spec>
std::vector<std::string> names_of(const std::vector<Spec>& specs) {
  std::vector<std::string> out;
  for (const Spec& s : specs) out.push_back(s.name);
  return out;
}

template <class Spec>
const Spec& find_spec(const std::vector<Spec>& specs, const std::string& name, const char* what) {
  for (const Spec& s : specs)
    if (s.name == name) return s;
  throw_unknown_choice(what, name, names_of(specs));
}

// The specs (of either kind) that list `key`.
template <class Spec>
std::vector<std::string> readers(const std::vector<Spec>& specs, const std::string& key) {
  std::vector<std::string> out;
  for (const Spec& s : specs)
    if (std::any_of(s.rows.begin(), s.rows.end(), [&](const std::string& r) { return detail::row_matches(r, key); }))
      out.push_back(s.name);
  return out;
}

std::string comma_list(const std::vector<std::string>& names) {
  std::string out;
  for (std::size_t i = 0; i < names.size(); ++i) out += (i ? ", " : "") + names[i];
  return out;
}

}  // namespace

const MethodSpec& method_spec(const std::string& name) { return find_spec(methods(), name, "method"); }
const MethodSpec* find_method(const std::string& name) {
  for (const MethodSpec& m : methods())
    if (m.name == name) return &m;
  return nullptr;
}
const ZSchemeSpec& z_scheme_spec(const std::string& name) { return find_spec(z_schemes(), name, "z_scheme"); }
std::vector<std::string> method_names() { return names_of(methods()); }
std::vector<std::string> z_scheme_names() { return names_of(z_schemes()); }
std::string section_method_names() {
  std::vector<std::string> names;
  for (const MethodSpec& m : methods())
    if (m.reads_sections) names.push_back(m.name);
  return comma_list(names);
}

namespace detail {
bool row_matches(const std::string& row, const std::string& key) {
  return row == key || (!row.empty() && row.back() == '.' && key.rfind(row, 0) == 0);
}
}  // namespace detail

std::string unused_param(const std::string& key, const std::string& method, const std::string& scheme) {
  const std::vector<std::string> by_method = readers(methods(), key), by_scheme = readers(z_schemes(), key);
  if (!by_method.empty() && std::find(by_method.begin(), by_method.end(), method) == by_method.end())
    return "only with --method " + comma_list(by_method);
  if (!by_scheme.empty() && std::find(by_scheme.begin(), by_scheme.end(), scheme) == by_scheme.end())
    return "only with --z-scheme " + comma_list(by_scheme);
  return {};
}

}  // namespace isoloft
