// @file core/sanitize.h
// @brief Names (ROI names, labels, file names from a manifest) made safe for
// where they are shown: a terminal (control bytes escaped) and a CSV cell
// read by a spreadsheet (formula triggers neutralised, OWASP's CSV-injection
// advice). Names are UTF-8 inside isoloft (decoded once, at read).
#pragma once

#include <string>
#include <string_view>

namespace isoloft {

/// `s` with every byte a terminal could act on escaped: C0 controls (ESC,
/// BEL, CR, LF, TAB, NUL ...) and DEL as \xNN, UTF-8 C1 controls
/// (U+0080..U+009F) and bidirectional overrides (U+202A..U+202E,
/// U+2066..U+2069) as \u{NNNN}, bytes that are not UTF-8 as \xNN. Printable
/// UTF-8 (accents, kana) is kept. A backslash is kept as is (the escapes are
/// for reading, not for parsing back).
[[nodiscard]] std::string terminal_text(std::string_view s);

/// One CSV cell (RFC 4180) that a spreadsheet shows as text: a cell starting
/// with =, +, -, @, TAB or CR (a formula or DDE trigger) gets a leading
/// single quote and is quoted; a cell holding a comma, a double quote, CR
/// or LF is quoted, its quotes doubled. Other cells are returned unchanged.
/// @warning The quote shows in the cell: "'=HYPERLINK(...)" is read back
///          with its quote (OWASP's advice; the value is never run).
[[nodiscard]] std::string csv_cell(std::string_view s);

/// The UTF-8 sequence starting at s[i]: its length (1..4), or 0 if the bytes
/// there are not UTF-8 (overlong, a surrogate, beyond U+10FFFF, cut short).
[[nodiscard]] std::size_t utf8_length(std::string_view s, std::size_t i);

/// Every byte of `s` is part of a UTF-8 sequence.
[[nodiscard]] bool is_utf8(std::string_view s);

}  // namespace isoloft
