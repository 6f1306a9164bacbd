#include "isoloft/core/option_names.h"

#include <atomic>

namespace isoloft {

namespace {
std::atomic<OptionStyle> g_style{OptionStyle::Flags};
}  // namespace

void set_option_style(OptionStyle style) { g_style = style; }
OptionStyle option_style() { return g_style; }

std::string option_name(std::string_view flag) {
  if (option_style() == OptionStyle::Flags) return std::string(flag);
  std::string out;
  for (std::size_t i = 0; i < flag.size(); ++i) {
    if (flag.compare(i, 2, "--") == 0) {
      ++i;
      continue;
    }
    out += flag[i] == '-' ? '_' : flag[i];
  }
  return out;
}

std::string option_given(std::string_view flag, std::string_view value) {
  std::string out = option_name(flag);
  if (option_style() == OptionStyle::Flags) {
    if (!value.empty()) out.append(" ").append(value);
    return out;
  }
  if (value.empty()) return out.append("=True");
  return out.append("='").append(value).append("'");
}

}  // namespace isoloft
