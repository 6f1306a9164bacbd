// @file core/error.h
// @brief The exceptions of isoloft.
// Every error a user can cause names the file (or option) and the problem in
// one line: the CLI prints what() and exits 1.
#pragma once

#include <stdexcept>
#include <string>

namespace isoloft {

/// Base of all isoloft errors.
struct Error : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Bad input data: unreadable, corrupt or inconsistent files. what() is
/// "<file>: <problem>".
struct InputError : Error {
  InputError(const std::string& file, const std::string& problem)
      : Error(file.empty() ? problem : file + ": " + problem), file(file), problem(problem) {}
  std::string file;
  std::string problem;
};

/// A parameter value outside its domain (from flags or a params file).
struct ParamError : Error {
  using Error::Error;
};

}  // namespace isoloft
