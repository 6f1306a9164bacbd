// @file io/text.h
// @brief Parsing helpers shared by the text readers (meshes, polylines,
// volume headers): whole-token numbers, tokens, trimmed lines with numbers.
//
// Numbers are C-locale decimal (std::from_chars): "12", "-3.5", "1e-3", a
// leading '+' allowed; a token parses only if all of it is the number.
// Floats parse straight to float (not via double), so the shortest float text
// the writers produce reads back bit for bit. Lines end at "\n", "\r\n" or a
// lone "\r"; a UTF-8 byte-order mark at the start of the text is skipped.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace isoloft::detail {

[[nodiscard]] bool is_space(char c);
[[nodiscard]] std::string_view trim(std::string_view s);

/// The whole token as a number; false if any of it is not.
[[nodiscard]] bool parse_number(std::string_view s, double& out);
[[nodiscard]] bool parse_number(std::string_view s, float& out);
[[nodiscard]] bool parse_number(std::string_view s, long long& out);

/// The shortest text that reads back to the same value.
[[nodiscard]] std::string shortest_text(double v);

/// Whitespace-separated tokens of `line` (cleared first), after cutting a
/// '#' comment if `hash_comments`.
void split_tokens(std::string_view line, std::vector<std::string_view>& tokens, bool hash_comments);

/// Line-by-line view of a text buffer with 1-based line numbers.
class Lines {
 public:
  Lines(const unsigned char* begin, const unsigned char* end);
  /// The next line without its end; false at the end of the text.
  bool next(std::string_view& line);
  /// Number of the line last returned by next().
  [[nodiscard]] std::size_t number() const { return number_; }
  /// Where the text after the last returned line starts (e.g. binary data).
  [[nodiscard]] const char* position() const { return p_; }

 private:
  const char* p_;
  const char* end_;
  std::size_t number_ = 0;
};

}  // namespace isoloft::detail
