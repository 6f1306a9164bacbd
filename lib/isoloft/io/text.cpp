#include "isoloft/io/text.h"

#include <charconv>
#include <cstring>

namespace isoloft::detail {

namespace {

template <class T>
bool parse_whole(std::string_view s, T& out) {
  if (!s.empty() && s[0] == '+') s.remove_prefix(1);
  const auto r = std::from_chars(s.data(), s.data() + s.size(), out);
  return r.ec == std::errc() && r.ptr == s.data() + s.size();
}

}  // namespace

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f'; }

std::string_view trim(std::string_view s) {
  while (!s.empty() && is_space(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_space(s.back())) s.remove_suffix(1);
  return s;
}

bool parse_number(std::string_view s, double& out) { return parse_whole(s, out); }
bool parse_number(std::string_view s, float& out) { return parse_whole(s, out); }
bool parse_number(std::string_view s, long long& out) { return parse_whole(s, out); }

std::string shortest_text(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

void split_tokens(std::string_view line, std::vector<std::string_view>& tokens, bool hash_comments) {
  tokens.clear();
  if (hash_comments) {
    const std::size_t h = line.find('#');
    if (h != std::string_view::npos) line = line.substr(0, h);
  }
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_space(line[i])) ++i;
    const std::size_t b = i;
    while (i < line.size() && !is_space(line[i])) ++i;
    if (i > b) tokens.push_back(line.substr(b, i - b));
  }
}

Lines::Lines(const unsigned char* begin, const unsigned char* end)
    : p_(reinterpret_cast<const char*>(begin)), end_(reinterpret_cast<const char*>(end)) {
  if (end_ - p_ >= 3 && std::memcmp(p_, "\xEF\xBB\xBF", 3) == 0) p_ += 3;  // UTF-8 byte-order mark
}

bool Lines::next(std::string_view& line) {
  if (p_ >= end_) return false;
  const char* e = p_;
  while (e < end_ && *e != '\n' && *e != '\r') ++e;
  line = std::string_view(p_, std::size_t(e - p_));
  if (e < end_ && *e == '\r') ++e;
  if (e < end_ && *e == '\n' && (e == p_ + line.size() || e[-1] == '\r')) ++e;
  p_ = e;
  ++number_;
  return true;
}

}  // namespace isoloft::detail
