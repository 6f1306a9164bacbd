// @file core/option_names.h
// @brief How an error names the option that fixes it: the CLI's flag
// (`--z-spacing`, `--input labels`, `--binarize`) or the Python keyword
// (`z_spacing`, `input='labels'`, `binarize=True`).
// The front end picks the style once, before any work (the Python module at
// import; the CLI keeps the default): a process runs one front end, and the
// messages are built deep in readers and pipeline stages (worker threads
// included), where no request object reaches.
#pragma once

#include <string>
#include <string_view>

namespace isoloft {

enum class OptionStyle { Flags, Keywords };

/// Set by the front end before any work; Flags by default.
void set_option_style(OptionStyle style);
[[nodiscard]] OptionStyle option_style();

/// The option's name: `flag` itself ("--z-spacing"), or its keyword
/// ("z_spacing"); several joined by '/' each converted ("--z-spacing/--slice-z").
[[nodiscard]] std::string option_name(std::string_view flag);

/// The option given with a value, as the user would type it: "--input labels"
/// or "input='labels'"; without a value, a switch: "--binarize" or "binarize=True".
[[nodiscard]] std::string option_given(std::string_view flag, std::string_view value = {});

}  // namespace isoloft
