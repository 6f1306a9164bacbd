// @file fuzz/entry_points.h
// @brief One entry point per input format, shared by the libFuzzer targets
// (fuzz_main.cpp, clang) and the corpus replay test (replay.cpp, any
// compiler): the bytes go through the reader as the CLI would use it. A
// rejected input throws isoloft::Error, which the entry point swallows; any
// other exception, a crash or a sanitizer report is a finding.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace isoloft::fuzz {

using EntryPoint = void (*)(const std::uint8_t* data, std::size_t size);

struct Target {
  const char* name;  ///< also the corpus folder name: fuzz/corpus/<name>
  EntryPoint run;
};

/// png, polylines, params, nifti, nrrd, metaimage, rtstruct, roi_names, label_names, csl, manifest.
const std::vector<Target>& targets();

/// The target named `name`, or nullptr.
const Target* find_target(const std::string& name);

}  // namespace isoloft::fuzz
