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
#include "cli/heap_tunables.h"
#include "isoloft/core/error.h"
#include "isoloft/core/sanitize.h"
#include "isoloft/io/atomic_file.h"

namespace {

// Returns how the heap is set up (the report's "heap"); started without the
// tunables (cli/heap_tunables.h), runs itself again with them when it can.
std::string rerun_on_huge_pages(char** argv) {
  using namespace isoloft::cli;
  if (const char* mark = std::getenv(kHeapRerun)) {
    if (std::string(mark) != "rerun") return std::string("as called (") + kHeapRerun + "=" + mark + ")";
    unset_heap_tunables();  // the caller's environment, for what this run starts
    return std::string("huge pages, one arena (GLIBC_TUNABLES ") + kHeapTunables + ")";
  }
  if (!set_heap_tunables()) {
    const char* given = std::getenv("GLIBC_TUNABLES");
    return std::string("as called (GLIBC_TUNABLES ") + (given ? given : "") + ")";
  }
  ::execv("/proc/self/exe", argv);
  // No /proc, or the exec failed: on as we are, with the caller's environment.
  unset_heap_tunables();
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
