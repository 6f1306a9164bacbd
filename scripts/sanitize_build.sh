#!/usr/bin/env bash
# The ASan + UBSan build (clang-14, -O0 -g1, any report fatal) in build-asan/,
# shared by test.sh (the library, the CLI, the corpus replay, a test subset)
# and fuzz.sh (the libFuzzer targets): the library carries libFuzzer's
# coverage instrumentation in both, so one build serves both.
#   sanitize_build.sh TARGET...
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
B="$ROOT/build-asan"
cmake -S "$ROOT" -B "$B" -DCMAKE_BUILD_TYPE=Release -DCMAKE_C_COMPILER=clang-14 -DCMAKE_CXX_COMPILER=clang++-14 \
  -DISOLOFT_SANITIZE=ON -DISOLOFT_BUILD_FUZZERS=ON -DISOLOFT_BUILD_TESTS=ON -DISOLOFT_BUILD_VALIDATION=OFF \
  -DISOLOFT_BUILD_EXPERIMENTS=OFF -DISOLOFT_ODR_CHECK=OFF -DISOLOFT_BUILD_PYTHON=OFF > "$B.log" 2>&1 || { cat "$B.log"; exit 1; }
cmake --build "$B" -j "${ISOLOFT_JOBS:-$(nproc)}" --target "$@" >> "$B.log" 2>&1 || { tail -n 80 "$B.log"; exit 1; }
