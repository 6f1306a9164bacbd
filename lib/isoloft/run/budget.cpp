#include "isoloft/run/budget.h"

#include <tbb/task_arena.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>

#include "isoloft/core/error.h"
#include "isoloft/run/inputs.h"

namespace isoloft {

namespace {

// Slices decoded at once while the contour stage runs (one per worker thread).
double slices_in_flight(double slices) { return std::min(slices, double(tbb::this_task_arena::max_concurrency())); }

// Per pixel of a slice in flight in the contour stage: the decoded image
// (Grid2u32), the contour and inside masks, the fill's two int label grids
// and its binarized copy.
constexpr double kImageBytes = 4, kMaskBytes = 2, kFillBytes = 9;

}  // namespace

double parse_size(const std::string& text, const std::string& option) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  double unit = 1;
  std::string suffix(end ? end : "");
  if (!suffix.empty() && (suffix.back() == 'B' || suffix.back() == 'b')) suffix.pop_back();
  if (suffix == "K" || suffix == "k") unit = 1024.0;
  else if (suffix == "M" || suffix == "m") unit = 1024.0 * 1024;
  else if (suffix == "G" || suffix == "g") unit = 1024.0 * 1024 * 1024;
  else if (suffix == "T" || suffix == "t") unit = 1024.0 * 1024 * 1024 * 1024;
  else if (!suffix.empty()) unit = -1;
  if (text.empty() || end == text.c_str() || unit < 0 || !std::isfinite(v) || v < 0)
    throw ParamError(option + ": '" + text + "' is not a size (e.g. 4G, 512M, 64K, bytes; 0 = no limit)");
  return v * unit;
}

std::string size_text(double bytes) {
  char buf[64];
  if (bytes >= 1024.0 * 1024 * 1024 * 1024) std::snprintf(buf, sizeof buf, "%.3g TiB", bytes / (1024.0 * 1024 * 1024 * 1024));
  else if (bytes >= 1024.0 * 1024 * 1024) std::snprintf(buf, sizeof buf, "%.3g GiB", bytes / (1024.0 * 1024 * 1024));
  else std::snprintf(buf, sizeof buf, "%.3g MiB", bytes / (1024.0 * 1024));
  return buf;
}

void check_budget(const std::string& option, const std::string& what, double need, double limit) {
  if (limit > 0 && need > limit)
    throw ParamError(option + ": " + what + " needs about " + size_text(need) + ", over the budget of " +
                     size_text(limit) + " (raise " + option + ", or 0 for no limit)");
}

double physical_memory_bytes() {
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGESIZE);
  return pages > 0 && page > 0 ? double(pages) * double(page) : 0.0;
}

void check_held_memory(const std::string& option, const std::string& what, double need, double limit) {
  if (limit > 0) return check_budget(option, what, need, limit);
  const double machine = physical_memory_bytes();
  if (machine > 0 && need > machine)
    throw ParamError(what + " needs about " + size_text(need) + ", more than this machine's memory (" +
                     size_text(machine) + "), even with " + option + " 0 (no limit)");
}

double stack_bytes(const SliceStack& st) {
  const double n = double(st.slices.size()), pixels = double(st.width) * double(st.height);
  const bool held = !st.load_image && !st.has_polygons();  // every slice's image in memory (volumes)
  // Run-length masks of every slice: ~1 (begin, end) pair of uint32 a row in each of the two.
  const double packed = n * double(st.height) * 2 * 2 * sizeof(std::uint32_t);
  return pixels * ((held ? n * kImageBytes : 0) + slices_in_flight(n) * (kImageBytes + kMaskBytes + kFillBytes)) + packed;
}

double input_bytes(const Inputs& in) {
  double bytes = 0;
  for (const Job& job : in.jobs) bytes = std::max(bytes, stack_bytes(job.stack));  // jobs run one at a time
  if (in.volume) bytes += double(in.volume->data.size()) * sizeof(float);
  return bytes;
}

}  // namespace isoloft
