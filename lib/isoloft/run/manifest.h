// @file run/manifest.h
// @brief A cohort's manifest (`isoloft batch`, isoloft.batch): a CSV with a
// header naming `input`, `name` and `options` columns, read and checked here
// once, before any case runs, so the batch (lib/python/isoloft/cohort.py)
// and the fuzzers see the same rows.
//
// The CSV as Python's csv module reads it (excel dialect, strict): a UTF-8
// byte order mark skipped, records ended by LF, CR LF or CR, a field quoted
// only when it starts with '"' (a '"' inside an unquoted field is a
// character), "" inside quotes a quote, blank lines skipped, columns beyond
// the header ignored. A quoted field running over a line end (a quote left
// open, rows merged), text after a closing quote, a quote never closed and
// bytes that are not UTF-8 refuse the whole manifest, naming its line.
//
// Each row becomes a case: input (relative paths from the manifest's
// folder, "." and repeated '/' dropped as pathlib does), name (given, else
// the input's file name up to its first '.'), options (split as POSIX
// shell words, Python's shlex.split). A row that cannot run carries an
// error (recorded as failed; the other rows run): no input, a NUL byte, a
// name that is not one plain folder name (a '/', a dot first, the batch's
// summary.csv, longer than a file name allows), options that do not split,
// that set what the batch sets (-o, --report, --threads, -q) or that give an
// output flag an absolute path or a `..` (outputs stay in OUT/NAME). A name
// used twice refuses the manifest (cases are keyed by name). Names in
// messages pass terminal_text() (core/sanitize.h).
#pragma once

#include <cstddef>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace isoloft {

/// A case's file names: NAME.json and NAME.<mesh format> (at most 4 more
/// bytes than ".json") under Linux's 255-byte file names.
inline constexpr std::size_t kMaxCaseNameBytes = 255 - 5 - 4;

/// Names the batch keeps for itself in OUT (dot-files too: its temp files, Dask's space).
inline constexpr const char* kReservedCaseNames[] = {"summary.csv"};

/// Flags of `isoloft reconstruct` that name a file or folder it writes: in a
/// case only relative paths inside OUT/NAME.
inline constexpr const char* kCaseOutputFlags[] = {"--volume", "--volumes", "--labelmap", "--rtstruct", "--rt-contours",
                                                   "--dump-stages"};
/// Flags the batch sets itself (a short -o or -q also as "-ofile", "-qo").
inline constexpr const char* kBatchFlags[] = {"-o", "--output", "--report", "--threads", "-q", "--quiet"};

/// One record of the manifest: its number (the header is 1) and its fields
/// by column name (absent: the record has fewer fields than the header).
struct ManifestRecord {
  std::size_t row = 0;
  std::size_t line = 0;  ///< where it starts in the file, from 1
  std::map<std::string, std::optional<std::string>> fields;
};

/// The records of a manifest's text (see the file comment). `where` names it.
/// \throw InputError naming `where`, the line and the problem.
std::vector<ManifestRecord> parse_manifest_csv(std::string_view text, const std::string& where);

/// One row as given: from a record, or from the Python API's dicts (their
/// options may already be a list of words).
struct ManifestRow {
  std::size_t row = 0;
  std::string input, name, options;
  std::optional<std::vector<std::string>> option_words;  ///< given as words: not split
};

/// A case to run, or (error not empty) a row recorded as failed.
struct ManifestCase {
  std::string input;  ///< absolute (`base` joined)
  std::string name;
  std::vector<std::string> options;
  std::string error;  ///< "<where>: row <n>: <why>", terminal-safe
};

/// A record's row: its input, name and options columns ("" if absent).
ManifestRow manifest_row(const ManifestRecord& record);

/// The cases of rows (see the file comment); `base`: the folder relative
/// inputs start from (absolute). \throw InputError naming `where` and the row
/// for a name used twice.
std::vector<ManifestCase> check_manifest_rows(const std::vector<ManifestRow>& rows, const std::string& base,
                                              const std::string& where);

/// The cases of the manifest file `path`: refused unless a regular file (a
/// FIFO would block), read, parsed and checked, relative inputs from its
/// folder (symbolic links resolved). \throw InputError naming `path`.
std::vector<ManifestCase> read_manifest(const std::string& path);

namespace detail {

/// `text` split as POSIX shell words (Python's shlex.split: quotes, backslash
/// escapes, no comments). \throw ParamError "No closing quotation" or "No
/// escaped character", as shlex says it.
std::vector<std::string> shell_words(std::string_view text);

/// Why `name` cannot be a case's folder and file stem, or "".
std::string case_name_problem(const std::string& name);

/// Why `options` cannot run in a case's folder, or "".
std::string case_options_problem(const std::vector<std::string>& options);

/// `path` as pathlib's PurePosixPath prints it (repeated '/' and "."
/// components dropped, no trailing '/'; "" is ".").
std::string pure_path(const std::string& path);

}  // namespace detail

}  // namespace isoloft
