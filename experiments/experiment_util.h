// Small helpers shared by the experiment programs.
#pragma once

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

}  // namespace isoloft::experiments
