// isoloft: command-line front end (CLI11). Subcommands:
//   reconstruct  slices -> closed surface meshes (+ volume, report)
//   synth        analytic shape -> contour/mask PNG stack + truth JSON
//   eval         mesh vs analytic truth -> distances and normal angles
//   batch        a cohort from a manifest on Dask (runs python3 -m isoloft.cohort)
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
#include <filesystem>
#include <fstream>
#include <iostream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "cli/commands.h"
#include "isoloft/core/error.h"
#include "isoloft/io/atomic_file.h"

int main(int argc, char** argv) {
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
    std::cerr << "isoloft: error: " << e.what() << "\n";
    return 1;
  } catch (const nlohmann::json::exception& e) {
    std::cerr << "isoloft: error: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "isoloft: error: " << e.what() << "\n";
    return 1;
  }
}
