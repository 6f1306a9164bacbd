#!/usr/bin/env bash
# The full set-up (setup.sh --full: it links the CLI with LTO and
# -Werror=odr, so two different definitions of one name fail the build), then
# the whole test suite: unit, property and oracle tests under ctest; then a
# lean AddressSanitizer + UndefinedBehaviorSanitizer build (build-asan/: the
# library, the CLI, the fuzz corpus replay and the readers', atomic outputs',
# contour and bad-input tests, -O1) and its tests. ISOLOFT_SANITIZE=0 skips it.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
JOBS="${ISOLOFT_JOBS:-$(nproc)}"
"$ROOT/scripts/setup.sh" --full
cd "$ROOT/build"
ctest --output-on-failure -j "$JOBS" --timeout 600

if [[ "${ISOLOFT_SANITIZE:-1}" != 0 ]]; then
  t0=$SECONDS
  ASAN="$ROOT/build-asan"
  cmake -S "$ROOT" -B "$ASAN" -DCMAKE_BUILD_TYPE=Release -DISOLOFT_SANITIZE=ON -DISOLOFT_BUILD_TESTS=ON \
    -DISOLOFT_BUILD_VALIDATION=OFF -DISOLOFT_BUILD_EXPERIMENTS=OFF -DISOLOFT_ODR_CHECK=OFF > "$ROOT/build-asan.log" 2>&1 \
    || { cat "$ROOT/build-asan.log"; exit 1; }
  cmake --build "$ASAN" -j "$JOBS" --target isoloft isoloft_tests isoloft_fuzz_replay >> "$ROOT/build-asan.log" 2>&1 \
    || { tail -n 80 "$ROOT/build-asan.log"; exit 1; }
  echo "test: sanitizer build done in $((SECONDS - t0)) s (log: build-asan.log)"
  # Any report is fatal and exits with its own status (not the CLI's 1 or 2);
  # leaks count.
  export ASAN_OPTIONS="exitcode=86:detect_leaks=1"
  export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1:exitcode=87"
  (cd "$ASAN" && ctest --output-on-failure -j "$JOBS" --timeout 900)
  echo "test: sanitizer build and tests took $((SECONDS - t0)) s"
fi
