#!/usr/bin/env bash
# The full set-up (setup.sh --full: it links the CLI with LTO and
# -Werror=odr, so two different definitions of one name fail the build), then
# the whole test suite: unit, property and oracle tests under ctest; then a
# lean AddressSanitizer + UndefinedBehaviorSanitizer build (sanitize_build.sh:
# build-asan/, clang-14, -O0 -g1: the library, the CLI, the fuzz corpus replay and
# the readers', atomic outputs', contour and bad-input tests) and its tests,
# and ISOLOFT_FUZZ_SECONDS (default 10) of fuzzing per reader.
# ISOLOFT_SANITIZE=0 skips both.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
JOBS="${ISOLOFT_JOBS:-$(nproc)}"
"$ROOT/scripts/setup.sh" --full
cd "$ROOT/build"
ctest --output-on-failure -j "$JOBS" --timeout 600

if [[ "${ISOLOFT_SANITIZE:-1}" != 0 ]]; then
  t0=$SECONDS
  # One goal (isoloft_sanitize_ci: the CLI, the test subset, the corpus replay
  # and the libFuzzer targets), so make packs all of it -j; fuzz.sh below then
  # finds its targets built.
  "$ROOT/scripts/sanitize_build.sh" isoloft_sanitize_ci
  echo "test: sanitizer build done in $((SECONDS - t0)) s (log: build-asan.log)"
  # Any report is fatal and exits with its own status (not the CLI's 1 or 2);
  # leaks count.
  export ASAN_OPTIONS="exitcode=86:detect_leaks=1"
  export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1:exitcode=87"
  export LSAN_OPTIONS="suppressions=$ROOT/scripts/lsan.supp"
  (cd "$ROOT/build-asan" && ctest --output-on-failure -j "$JOBS" --timeout 900)
  echo "test: sanitizer build and tests took $((SECONDS - t0)) s"
  # A short libFuzzer run of every reader from the committed corpus (a crash
  # fails the run; scripts/fuzz.sh 60 is the minute-per-target run).
  t0=$SECONDS
  "$ROOT/scripts/fuzz.sh" "${ISOLOFT_FUZZ_SECONDS:-10}"
  echo "test: fuzzing took $((SECONDS - t0)) s"
fi
