#include "isoloft/core/params.h"

#include <charconv>
#include <sstream>

namespace isoloft {

namespace {

std::string number_text(double v) {
  std::ostringstream o;
  o << v;
  return o.str();
}

}  // namespace

std::string Range::text() const {
  const bool has_lo = lo > -std::numeric_limits<double>::max(), has_hi = hi < std::numeric_limits<double>::max();
  if (has_lo && has_hi)
    return std::string(lo_open ? "(" : "[") + number_text(lo) + ", " + number_text(hi) + (hi_open ? ")" : "]");
  if (has_lo) return (lo_open ? "> " : ">= ") + number_text(lo);
  if (has_hi) return (hi_open ? "< " : "<= ") + number_text(hi);
  return "any";
}

void throw_unknown_choice(const std::string& what, const std::string& name, const std::vector<std::string>& choices) {
  std::string list;
  for (std::size_t i = 0; i < choices.size(); ++i)
    list += (i == 0 ? "" : i + 1 == choices.size() ? " or " : ", ") + choices[i];
  throw ParamError(what + ": unknown value '" + name + "' (expected " + list + ")");
}

namespace detail {

std::string json_type_name(const nlohmann::json& j) {
  if (j.is_boolean()) return "a boolean";
  if (j.is_number_integer()) return "an integer";
  if (j.is_number()) return "a number";
  if (j.is_string()) return "a string";
  if (j.is_object()) return "an object";
  if (j.is_array()) return "an array";
  return "null";
}

void throw_bad_value(const std::string& key, const std::string& expected, const nlohmann::json& got) {
  throw ParamError(key + ": expected " + expected + ", got " + json_type_name(got) + " (" + got.dump() + ")");
}

void throw_out_of_range(const std::string& key, const Range& r, const nlohmann::json& got) {
  std::string value = got.dump();
  if (got.is_number_float() && std::isnan(got.get<double>())) value = "nan";
  throw ParamError(key + ": must be " + r.text() + ", got " + value);
}

}  // namespace detail

nlohmann::json parse_value(ParamType type, const std::string& text, const std::string& what) {
  auto bad = [&](const char* expected) -> ParamError {
    return ParamError(what + ": '" + text + "' is not " + expected);
  };
  switch (type) {
    case ParamType::Bool:
      if (text == "true" || text == "1") return true;
      if (text == "false" || text == "0") return false;
      throw bad("true or false");
    case ParamType::Enum:
      return text;
    case ParamType::Int: {
      const char* b = text.data() + (text.size() > 1 && text[0] == '+' ? 1 : 0);
      const char* e = text.data() + text.size();
      if (b < e && *b == '-') {
        std::int64_t v = 0;
        const auto r = std::from_chars(b, e, v);
        if (r.ec != std::errc() || r.ptr != e) throw bad("an integer");
        return v;
      }
      std::uint64_t v = 0;
      const auto r = std::from_chars(b, e, v);
      if (r.ec == std::errc::result_out_of_range) return std::numeric_limits<std::uint64_t>::max();  // out of any range
      if (r.ec != std::errc() || r.ptr != e) throw bad("an integer");
      return v;
    }
    case ParamType::Number: {
      // strtod, not from_chars: it takes "nan" and "inf" in any case, which
      // the range then rejects with a clear message.
      if (text.empty()) throw bad("a number");
      char* end = nullptr;
      const double v = std::strtod(text.c_str(), &end);
      if (end != text.c_str() + text.size()) throw bad("a number");
      return v;
    }
  }
  throw bad("a value");
}

std::string describe_row(const std::string& unit, ParamType type, const Range& range,
                         const std::vector<std::string>& choices, const std::string& doc) {
  std::string valid;
  switch (type) {
    case ParamType::Bool: valid = "true or false"; break;
    case ParamType::Enum:
      for (std::size_t i = 0; i < choices.size(); ++i) valid += (i ? "|" : "") + choices[i];
      break;
    case ParamType::Int: valid = "integer " + range.text(); break;
    case ParamType::Number: valid = range.text(); break;
  }
  return (unit.empty() ? "" : unit + ", ") + valid + ": " + doc;
}

namespace {

void print_commented(const nlohmann::json& j, const std::string& path, int indent,
                     const std::function<std::string(const std::string&)>& comment, std::string& out) {
  const std::string pad(std::size_t(indent) + 2, ' ');
  out += "{\n";
  std::size_t i = 0;
  for (const auto& [k, v] : j.items()) {
    const std::string key = path.empty() ? k : path + "." + k;
    if (!v.is_object()) {
      const std::string c = comment(key);
      if (!c.empty()) out += pad + "// " + c + "\n";
    }
    out += pad + nlohmann::json(k).dump() + ": ";
    if (v.is_object()) print_commented(v, key, indent + 2, comment, out);
    else out += v.dump();
    out += ++i < j.size() ? ",\n" : "\n";
  }
  out += std::string(std::size_t(indent), ' ') + "}";
}

}  // namespace

std::string commented_json(const nlohmann::json& values, const std::function<std::string(const std::string&)>& comment) {
  std::string out;
  print_commented(values, "", 0, comment, out);
  return out + "\n";
}

}  // namespace isoloft
