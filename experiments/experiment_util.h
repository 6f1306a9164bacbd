// Small helpers shared by the experiment programs.
#pragma once

#include <algorithm>
#include <sstream>
#include <string>
#include <vector>

namespace isoloft::experiments {

/// "a,b,c" -> {"a", "b", "c"} (command-line lists).
inline std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> v;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) v.push_back(item);
  return v;
}

/// Median of repeated timings (0 for none).
inline double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

}  // namespace isoloft::experiments
