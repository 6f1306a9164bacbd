#!/usr/bin/env bash
# The full set-up (setup.sh --full: it links the CLI with LTO and
# -Werror=odr, so two different definitions of one name fail the build), then
# the whole test suite: unit, property and oracle tests under ctest.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$ROOT/scripts/setup.sh" --full
cd "$ROOT/build"
ctest --output-on-failure -j "${ISOLOFT_JOBS:-$(nproc)}" --timeout 600
