#!/usr/bin/env bash
# The ASan + UBSan build (clang-14, -O0 -g1, any report fatal) in build-asan/,
# shared by test.sh (the library, the CLI, the corpus replay, a test subset)
# and fuzz.sh (the libFuzzer targets): the library carries libFuzzer's
# coverage instrumentation in both, so one build serves both.
#   sanitize_build.sh TARGET...
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
B="$ROOT/build-asan"
# Linked by lld (lld-14): an ASan executable here links in ~2 CPU s instead of
# GNU ld's ~9 (fuzz_png 2.0 vs 8.9, isoloft_tests 2.3 vs 8.6), and this build
# links fourteen of them.
cmake -S "$ROOT" -B "$B" -DCMAKE_BUILD_TYPE=Release -DCMAKE_C_COMPILER=clang-14 -DCMAKE_CXX_COMPILER=clang++-14 \
  -DCMAKE_EXE_LINKER_FLAGS=-fuse-ld=lld-14 -DCMAKE_SHARED_LINKER_FLAGS=-fuse-ld=lld-14 \
  -DISOLOFT_SANITIZE=ON -DISOLOFT_BUILD_FUZZERS=ON -DISOLOFT_BUILD_TESTS=ON -DISOLOFT_BUILD_VALIDATION=OFF \
  -DISOLOFT_BUILD_EXPERIMENTS=OFF -DISOLOFT_ODR_CHECK=OFF -DISOLOFT_BUILD_PYTHON=OFF > "$B.log" 2>&1 || { cat "$B.log"; exit 1; }
cmake --build "$B" -j "${ISOLOFT_JOBS:-$(nproc)}" --target "$@" >> "$B.log" 2>&1 || { tail -n 80 "$B.log"; exit 1; }
