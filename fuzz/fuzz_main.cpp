// libFuzzer target for one format, chosen at build time (ISOLOFT_FUZZ_TARGET).
#include <cstdlib>

#include "entry_points.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const isoloft::fuzz::Target* target = isoloft::fuzz::find_target(ISOLOFT_FUZZ_TARGET);
  if (!target) std::abort();
  target->run(data, size);
  return 0;
}
