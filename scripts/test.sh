#!/usr/bin/env bash
# Set-up as in example.sh, then the whole test suite (unit, property and
# oracle tests under ctest) and an end-to-end run of the CLI on the example.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$ROOT/scripts/setup.sh"
cd "$ROOT/build"
ctest --output-on-failure -j "${ISOLOFT_JOBS:-$(nproc)}" --timeout 600
