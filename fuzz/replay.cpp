// Replays the committed fuzz corpus (fuzz/corpus/<target>/*) through the
// same entry points as the fuzzers: every input that once crashed, hung or
// leaked must now be rejected cleanly or read. Exit 1 naming the target if a
// corpus folder is missing or empty.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>

#include "entry_points.h"

int main(int argc, char** argv) {
  namespace fs = std::filesystem;
  const fs::path root = argc > 1 ? fs::path(argv[1]) : fs::path(ISOLOFT_FUZZ_CORPUS);
  std::size_t total = 0;
  for (const auto& t : isoloft::fuzz::targets()) {
    std::size_t n = 0;
    const fs::path dir = root / t.name;
    if (fs::is_directory(dir))
      for (const auto& e : fs::directory_iterator(dir)) {
        std::ifstream in(e.path(), std::ios::binary);
        const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        std::printf("%s: %s (%zu bytes)\n", t.name, e.path().filename().c_str(), bytes.size());
        std::fflush(stdout);
        t.run(bytes.data(), bytes.size());
        ++n;
      }
    if (n == 0) {
      std::fprintf(stderr, "%s: no corpus files (want at least one)\n", dir.c_str());
      return 1;
    }
    total += n;
  }
  std::printf("replayed %zu corpus files\n", total);
  return 0;
}
