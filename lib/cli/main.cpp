// isoloft: command-line front end (CLI11). Subcommands:
//   reconstruct  slices -> closed surface meshes (+ volume, report)
//   synth        analytic shape -> contour/mask PNG stack + truth JSON
//   eval         mesh vs analytic truth -> distances and normal angles
// Exit codes: 0 success, 1 bad input or parameters (one line naming the file
// and the problem), 2 command-line usage errors (from CLI11).
#include <CLI/CLI.hpp>
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

int main(int argc, char** argv) {
  CLI::App app{"isoloft: smooth closed surfaces from parallel planar contours (Marker, Braude, Museth & Breen 2006)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string(ISOLOFT_VERSION) + " (" + ISOLOFT_GIT + ")");
  isoloft::cli::Commands commands(app, argc, argv);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  try {
    return commands.run();
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
