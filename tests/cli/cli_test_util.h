// The isoloft executable under test: run it with arguments in a fresh
// temporary directory, capture exit status, stdout and stderr.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "isoloft/core/grid.h"
#include "isoloft/io/png.h"
#include "isoloft/io/volume.h"
#include "io/io_test_util.h"  // read_text

namespace isoloft::test {

namespace fs = std::filesystem;

struct CliRun {
  int code;
  std::string err, out;
};

class Cli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("isoloft_cli_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  CliRun run(const std::string& args) {
    const std::string err = (dir_ / "stderr.txt").string(), out = (dir_ / "stdout.txt").string();
    const std::string cmd = std::string(ISOLOFT_CLI) + " " + args + " >" + out + " 2>" + err;
    const int status = std::system(cmd.c_str());
    auto slurp = [](const std::string& p) {
      std::ifstream in(p);
      std::stringstream ss;
      ss << in.rdbuf();
      return ss.str();
    };
    return {WEXITSTATUS(status), slurp(err), slurp(out)};
  }
  std::string p(const std::string& name) const { return (dir_ / name).string(); }

  // A 24x24 contour image of a circle.
  void write_circle(const std::string& path, int size = 24, std::uint8_t white = 255) {
    Grid2u8 g(size, size, 0);
    for (int y = 0; y < size; ++y)
      for (int x = 0; x < size; ++x) {
        const double r = std::hypot(x - size / 2.0, y - size / 2.0);
        if (std::abs(r - size / 4.0) < 0.6) g(x, y) = white;
      }
    write_png(path, g);
  }
  // Files in dir_ other than our captured stdout/stderr (e.g. half-written output).
  std::vector<std::string> leftovers(const std::string& stem) {
    std::vector<std::string> v;
    for (const auto& e : fs::directory_iterator(dir_))
      if (e.path().filename().string().rfind(stem, 0) == 0 || e.path().filename().string().find("." + stem) == 0) v.push_back(e.path().filename().string());
    return v;
  }
  fs::path dir_;
};

/// The shared RT Structure Set (data/rtstruct).
/// Two boxes, label 4 (12 x 10 voxels) and label 9 (6 x 14), on slices 1, 3,
/// 5, 7 (1 x 1 x 2 mm voxels), as a label volume at `path`.
inline void write_two_labels(const std::string& path) {
  Volume v;
  v.nx = 32, v.ny = 28, v.nz = 9;
  v.spacing = {1.0, 1.0, 2.0};
  v.integer = true;
  v.data.assign(std::size_t(v.nx) * v.ny * v.nz, 0.0f);
  for (int k = 1; k < 8; k += 2) {
    for (int j = 6; j < 16; ++j)
      for (int i = 4; i < 16; ++i) v.data[v.index(i, j, k)] = 4;
    for (int j = 8; j < 22; ++j)
      for (int i = 20; i < 26; ++i) v.data[v.index(i, j, k)] = 9;
  }
  write_volume(path, v);
}

inline const std::string kRtss = std::string(ISOLOFT_SOURCE_DIR) + "/data/rtstruct/rtss.dcm";

}  // namespace isoloft::test
