// @file run/manifest.cpp
// @brief A cohort's manifest read and checked (see manifest.h).
#include "isoloft/run/manifest.h"

#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>

#include "isoloft/core/error.h"
#include "isoloft/core/sanitize.h"

namespace fs = std::filesystem;

namespace isoloft {

namespace {

std::string shown_name(const std::string& s) { return "'" + terminal_text(s) + "'"; }

// ASCII whitespace around a name (what Python's str.strip() removes from ASCII text).
std::string strip(const std::string& s) {
  const char* const ws = " \t\n\r\f\v";
  const std::size_t a = s.find_first_not_of(ws);
  if (a == std::string::npos) return {};
  return s.substr(a, s.find_last_not_of(ws) - a + 1);
}

template <std::size_t N>
bool one_of(std::string_view s, const char* const (&list)[N]) {
  return std::any_of(std::begin(list), std::end(list), [&](const char* x) { return s == x; });
}

}  // namespace

// ---------------------------------------------------------------- CSV

std::vector<ManifestRecord> parse_manifest_csv(std::string_view text, const std::string& where) {
  if (text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);  // a byte order mark (Excel's UTF-8)
  if (!is_utf8(text)) {
    std::size_t at = 0;
    while (at < text.size()) {
      const std::size_t n = utf8_length(text, at);
      if (n == 0) break;
      at += n;
    }
    throw InputError(where, "not UTF-8 text (byte " + std::to_string(at) + " of the text)");
  }
  enum class State { StartRecord, StartField, InField, InQuoted, QuoteInQuoted };
  State state = State::StartRecord;
  std::vector<std::vector<std::string>> records;
  std::vector<std::size_t> record_lines;
  std::vector<std::string> fields;
  std::string field;
  std::size_t line = 1, record_line = 1, open_line = 0, span_line = 0;
  bool spans = false;  // a quoted field of this record holds a line end (opened on span_line)
  auto fail = [&](std::size_t at, const std::string& why) {
    return InputError(where, "line " + std::to_string(at) + ": " + why + " (an unbalanced quote?)");
  };
  auto end_field = [&] {
    fields.push_back(std::move(field));
    field.clear();
  };
  auto end_record = [&] {
    end_field();
    if (spans) throw fail(span_line, "a field spans several lines");
    records.push_back(std::move(fields));
    record_lines.push_back(record_line);
    fields.clear();
    state = State::StartRecord;
  };
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    const bool eol = c == '\n' || c == '\r';
    // CR LF is one line end; a bare CR ends a line too.
    const bool counts = c == '\n' || (c == '\r' && (i + 1 >= text.size() || text[i + 1] != '\n'));
    switch (state) {
      case State::StartRecord:
        if (eol) break;  // a blank line: no record
        record_line = line;
        state = State::StartField;
        [[fallthrough]];
      case State::StartField:
        if (c == '"') {
          state = State::InQuoted, open_line = line;
        } else if (c == ',') {
          end_field();
        } else if (eol) {
          end_record();
        } else {
          field += c, state = State::InField;
        }
        break;
      case State::InField:
        if (c == ',') end_field(), state = State::StartField;
        else if (eol) end_record();
        else field += c;  // a quote inside an unquoted field is a character
        break;
      case State::InQuoted:
        if (c == '"') state = State::QuoteInQuoted;
        else field += c;
        if (eol && !spans) spans = true, span_line = open_line;
        break;
      case State::QuoteInQuoted:
        if (c == '"') {
          field += c, state = State::InQuoted;
        } else if (c == ',') {
          end_field(), state = State::StartField;
        } else if (eol) {
          end_record();
        } else {
          throw fail(line, "',' expected after '\"'");
        }
        break;
    }
    if (counts) ++line;
  }
  if (state == State::InQuoted) throw fail(line, "unexpected end of data");
  if (state != State::StartRecord) end_record();

  std::vector<ManifestRecord> out;
  if (records.empty()) return out;
  const std::vector<std::string>& header = records.front();
  for (std::size_t r = 1; r < records.size(); ++r) {
    ManifestRecord rec;
    rec.row = r + 1;
    rec.line = record_lines[r];
    for (std::size_t k = 0; k < header.size(); ++k)  // a column named twice: the later one (as csv.DictReader)
      rec.fields[header[k]] = k < records[r].size() ? std::optional(records[r][k]) : std::nullopt;
    out.push_back(std::move(rec));
  }
  return out;
}

// ---------------------------------------------------------------- rows

namespace detail {

std::vector<std::string> shell_words(std::string_view s) {
  std::vector<std::string> words;
  std::string word;
  bool in_word = false;
  const auto space = [](char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; };
  for (std::size_t i = 0; i < s.size(); ++i) {
    const char c = s[i];
    if (space(c)) {
      if (in_word) words.push_back(std::move(word)), word.clear(), in_word = false;
      continue;
    }
    in_word = true;
    if (c == '\\') {
      if (++i >= s.size()) throw ParamError("No escaped character");
      word += s[i];
    } else if (c == '\'') {
      const std::size_t close = s.find('\'', i + 1);
      if (close == std::string_view::npos) throw ParamError("No closing quotation");
      word.append(s.substr(i + 1, close - i - 1));
      i = close;
    } else if (c == '"') {
      for (++i;; ++i) {
        if (i >= s.size()) throw ParamError("No closing quotation");
        if (s[i] == '"') break;
        // Inside double quotes a backslash escapes only '"' and itself.
        if (s[i] == '\\' && i + 1 < s.size() && (s[i + 1] == '"' || s[i + 1] == '\\')) ++i;
        word += s[i];
      }
    } else {
      word += c;
    }
  }
  if (in_word) words.push_back(std::move(word));
  return words;
}

std::string case_name_problem(const std::string& name) {
  if (name.empty()) return "is empty (give one in the 'name' column)";
  if (name.find('\0') != std::string::npos) return "holds a NUL byte";
  if (name.find('/') != std::string::npos || name == "." || name == "..") return "is not a folder name";
  if (!name.empty() && name.front() == '.') return "starts with a dot (the batch's own files)";
  if (one_of(name, kReservedCaseNames)) return "is reserved for the batch's " + name;
  if (name.size() > kMaxCaseNameBytes)
    return "is longer than " + std::to_string(kMaxCaseNameBytes) + " bytes (file names)";
  return {};
}

std::string case_options_problem(const std::vector<std::string>& options) {
  for (std::size_t i = 0; i < options.size(); ++i) {
    const std::string& opt = options[i];
    if (opt.find('\0') != std::string::npos) return "an option holds a NUL byte";
    const std::size_t eq = opt.find('=');
    const std::string flag = opt.substr(0, eq);
    // A short flag takes its value glued on ("-ox.ply"), and short switches combine ("-qo").
    const bool short_batch = opt.size() > 1 && opt[0] == '-' && (opt[1] == 'o' || opt[1] == 'q');
    if (one_of(flag, kBatchFlags) || short_batch)
      return terminal_text(short_batch ? opt.substr(0, 2) : flag) + " is set by the batch";
    if (!one_of(flag, kCaseOutputFlags)) continue;
    std::string value;
    if (eq != std::string::npos) {
      value = opt.substr(eq + 1);
    } else {
      if (i + 1 >= options.size()) return flag + " needs a value";
      value = options[i + 1];
    }
    const std::string p = pure_path(value);
    const bool up = p == ".." || p.starts_with("../") || p.ends_with("/..") || p.find("/../") != std::string::npos;
    if (p.starts_with("/") || up)
      return flag + " " + terminal_text(value) + ": outputs stay in the case's folder (a relative path without '..')";
  }
  return {};
}

std::string pure_path(const std::string& path) {
  std::vector<std::string> parts;
  std::size_t at = 0;
  while (at <= path.size()) {
    const std::size_t slash = std::min(path.find('/', at), path.size());
    const std::string part = path.substr(at, slash - at);
    if (!part.empty() && part != ".") parts.push_back(part);
    at = slash + 1;
  }
  std::string out = !path.empty() && path.front() == '/' ? "/" : "";
  for (std::size_t k = 0; k < parts.size(); ++k) out += (k ? "/" : "") + parts[k];
  return out.empty() ? "." : out;
}

}  // namespace detail

ManifestRow manifest_row(const ManifestRecord& record) {
  ManifestRow row;
  row.row = record.row;
  auto get = [&](const char* key) {
    const auto it = record.fields.find(key);
    return it == record.fields.end() || !it->second ? std::string() : *it->second;
  };
  row.input = get("input"), row.name = get("name"), row.options = get("options");
  return row;
}

std::vector<ManifestCase> check_manifest_rows(const std::vector<ManifestRow>& rows, const std::string& base,
                                              const std::string& where) {
  std::vector<ManifestCase> cases;
  std::set<std::string> names;
  for (const ManifestRow& row : rows) {
    ManifestCase c;
    std::string given = row.input;
    const bool nul_input = given.find('\0') != std::string::npos;
    given.erase(std::remove(given.begin(), given.end(), '\0'), given.end());
    const std::string src = detail::pure_path(given);
    c.input = !src.empty() && src.front() == '/' ? src : detail::pure_path(base + "/" + src);
    c.name = strip(row.name);
    if (c.name.empty()) {
      const std::string file = c.input == "/" ? "" : c.input.substr(c.input.rfind('/') + 1);
      c.name = row.input.empty() ? "row" + std::to_string(row.row) : file.substr(0, file.find('.'));
    }
    std::string error;
    if (row.option_words) {
      c.options = *row.option_words;
    } else {
      try {
        c.options = detail::shell_words(row.options);
      } catch (const ParamError& e) {
        error = std::string("options: ") + e.what();
      }
    }
    if (row.input.empty()) error = "no 'input'";
    else if (nul_input) error = "the input holds a NUL byte";
    if (const std::string problem = detail::case_name_problem(c.name); !problem.empty())
      error = "the name " + shown_name(c.name) + " " + problem;
    if (error.empty()) error = detail::case_options_problem(c.options);
    if (!c.name.empty() && !names.insert(c.name).second)
      throw InputError(where, "row " + std::to_string(row.row) + ": the name " + shown_name(c.name) + " is used twice");
    if (!error.empty()) c.error = terminal_text(where) + ": row " + std::to_string(row.row) + ": " + error;
    cases.push_back(std::move(c));
  }
  return cases;
}

std::vector<ManifestCase> read_manifest(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0)
    throw InputError(path, std::string("cannot read the manifest (") + std::strerror(errno) + ")");
  if (!S_ISREG(st.st_mode)) throw InputError(path, "the manifest is not a regular file");
  std::ifstream f(path, std::ios::binary);
  if (!f) throw InputError(path, std::string("cannot read the manifest (") + std::strerror(errno) + ")");
  const std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  if (f.bad()) throw InputError(path, std::string("cannot read the manifest (") + std::strerror(errno) + ")");
  std::vector<ManifestRow> rows;
  for (const ManifestRecord& r : parse_manifest_csv(text, path)) rows.push_back(manifest_row(r));
  std::error_code ec;
  fs::path base = fs::weakly_canonical(fs::absolute(path), ec).parent_path();
  if (ec) base = fs::absolute(path).parent_path();
  return check_manifest_rows(rows, base.string(), path);
}

}  // namespace isoloft
