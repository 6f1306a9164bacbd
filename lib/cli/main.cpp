// isoloft: command-line front end (CLI11). Subcommands:
//   reconstruct  slices -> closed surface meshes (+ volume, report)
//   synth        analytic shape -> contour/mask PNG stack + truth JSON
//   eval         mesh vs analytic truth -> distances and normal angles
//   batch        a cohort from a manifest on Dask (runs python3 -m isoloft.cohort)
//   join-slabs   one object's z slab meshes (reconstruct --z-slab) welded into its surface
// Exit codes: 0 success, 1 bad input or parameters (one line naming the file
// and the problem), 2 command-line usage errors (from CLI11); a run ended by
// SIGINT, SIGTERM or SIGHUP dies by that signal with its temp files removed.
#include <CLI/CLI.hpp>
#include <malloc.h>
#include <sys/resource.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "cli/commands.h"
#include "isoloft/core/error.h"
#include "isoloft/core/sanitize.h"
#include "isoloft/io/atomic_file.h"

namespace {

// The heap on transparent huge pages, one arena (docs/decisions.md: the
// CLI's heap). The pipeline touches fresh memory all along (slice images,
// fields, meshes); on 4 KB pages a fault per page was a fifth of a run on one
// VM (x1.10 slower with the tunables on another, where faults are cheap), and
// glibc's per-thread arenas still grow 4 KB at a time. glibc reads its
// tunables at start-up only, so the process runs itself once more with them
// added, unless the caller's GLIBC_TUNABLES names either or
// ISOLOFT_HUGE_PAGES is set (0: run as called). The re-run puts the caller's
// environment back, so what it starts (the cohort runner) gets that.
constexpr const char* kRerun = "ISOLOFT_HUGE_PAGES", *kCallersTunables = "ISOLOFT_CALLERS_GLIBC_TUNABLES";
constexpr const char* kTunables = "glibc.malloc.hugetlb=1:glibc.malloc.arena_max=1";

// Returns how the heap is set up (the report's "heap"); runs again instead
// when it can.
std::string rerun_on_huge_pages(char** argv) {
  if (const char* mark = std::getenv(kRerun)) {
    if (std::string(mark) != "rerun") return std::string("as called (") + kRerun + "=" + mark + ")";
    const char* callers = std::getenv(kCallersTunables);
    if (callers && *callers) ::setenv("GLIBC_TUNABLES", callers, 1);
    else ::unsetenv("GLIBC_TUNABLES");
    ::unsetenv(kCallersTunables);
    ::unsetenv(kRerun);
    return std::string("huge pages, one arena (GLIBC_TUNABLES ") + kTunables + ")";
  }
  const char* given = std::getenv("GLIBC_TUNABLES");
  const std::string before = given ? given : "";
  if (before.find("glibc.malloc.hugetlb") != std::string::npos || before.find("glibc.malloc.arena_max") != std::string::npos)
    return "as called (GLIBC_TUNABLES " + before + ")";
  const std::string tunables = before + (before.empty() ? "" : ":") + kTunables;
  if (::setenv(kCallersTunables, before.c_str(), 1) == 0 && ::setenv(kRerun, "rerun", 1) == 0 &&
      ::setenv("GLIBC_TUNABLES", tunables.c_str(), 1) == 0)
    ::execv("/proc/self/exe", argv);
  // No /proc, or the exec failed: on as we are, with the caller's environment.
  ::unsetenv(kRerun);
  ::unsetenv(kCallersTunables);
  if (given) ::setenv("GLIBC_TUNABLES", before.c_str(), 1);
  else ::unsetenv("GLIBC_TUNABLES");
  return "as called (running again on huge pages failed)";
}

}  // namespace

int main(int argc, char** argv) {
  const std::string heap = rerun_on_huge_pages(argv);
#ifdef M_MMAP_THRESHOLD
  // The pipeline allocates and frees slice-sized grids (~1 MB) all along:
  // glibc would map and unmap each (its dynamic threshold) and trim the heap
  // after frees, so every grid's pages fault in afresh (~10 % of the run in
  // the kernel zeroing pages). Fixed thresholds keep them in the heap.
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
#endif
  CLI::App app{"isoloft: smooth closed surfaces from parallel planar contours (Marker, Braude, Museth & Breen 2006)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string(ISOLOFT_VERSION) + " (" + ISOLOFT_GIT + ")");
  isoloft::cli::Commands commands(app, argc, argv);
  commands.set_heap(heap);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  // A run ended by SIGINT, SIGTERM or SIGHUP removes its temp files first.
  isoloft::remove_temp_files_on_signals();
  try {
    return commands.run();
  } catch (const std::bad_alloc&) {
    std::cerr << "isoloft: error: out of memory" << (commands.activity().empty() ? "" : " while " + commands.activity())
              << " (within the --max-memory estimate, but more than this machine could give)\n";
    return 1;
  } catch (const isoloft::Error& e) {
    std::cerr << "isoloft: error: " << isoloft::terminal_text(e.what()) << "\n";
    return 1;
  } catch (const nlohmann::json::exception& e) {
    std::cerr << "isoloft: error: " << isoloft::terminal_text(e.what()) << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "isoloft: error: " << isoloft::terminal_text(e.what()) << "\n";
    return 1;
  }
}
