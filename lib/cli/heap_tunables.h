// @file heap_tunables.h
// @brief The CLI's heap on transparent huge pages with one arena
// (docs/decisions.md: the CLI's heap), set through glibc's tunables, which
// glibc reads at start-up only: the process that reconstructs must be
// started with them. Used by the `isoloft` launcher (it starts isoloft-cli
// so) and by isoloft-cli itself (started without them, it runs itself once
// more). Neither when the caller's GLIBC_TUNABLES names either tunable or
// ISOLOFT_HUGE_PAGES is set (0: run as called). The started process puts
// the caller's environment back, so what it starts (the cohort runner) gets that.
#pragma once

#include <cstdlib>
#include <string>

namespace isoloft::cli {

/// The launcher's file name, and the CLI's it starts from the same folder.
inline constexpr const char* kLauncherName = "isoloft", *kCliName = "isoloft-cli";

inline constexpr const char* kHeapRerun = "ISOLOFT_HUGE_PAGES", *kCallersTunables = "ISOLOFT_CALLERS_GLIBC_TUNABLES";
inline constexpr const char* kHeapTunables = "glibc.malloc.hugetlb=1:glibc.malloc.arena_max=1";

/// Undoes set_heap_tunables() (the exec failed): the caller's environment.
inline void unset_heap_tunables() {
  const char* callers = std::getenv(kCallersTunables);
  if (callers && *callers) ::setenv("GLIBC_TUNABLES", callers, 1);
  else ::unsetenv("GLIBC_TUNABLES");
  ::unsetenv(kCallersTunables);
  ::unsetenv(kHeapRerun);
}

/// Sets the environment for a process started with the tunables; false
/// (nothing changed) when the caller's settings say to run as called, or
/// when this process was already started so.
inline bool set_heap_tunables() {
  if (std::getenv(kHeapRerun)) return false;
  const char* given = std::getenv("GLIBC_TUNABLES");
  const std::string before = given ? given : "";
  if (before.find("glibc.malloc.hugetlb") != std::string::npos || before.find("glibc.malloc.arena_max") != std::string::npos)
    return false;
  const std::string tunables = before + (before.empty() ? "" : ":") + kHeapTunables;
  if (::setenv(kCallersTunables, before.c_str(), 1) == 0 && ::setenv(kHeapRerun, "rerun", 1) == 0 &&
      ::setenv("GLIBC_TUNABLES", tunables.c_str(), 1) == 0)
    return true;
  unset_heap_tunables();
  return false;
}

}  // namespace isoloft::cli
