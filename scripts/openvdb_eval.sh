#!/usr/bin/env bash
# Experiment, not a test (not in ctest; issue 37): OpenVDB's adaptive mesher
# against isoloft's Marching Cubes + certified decimator on isoloft's own
# field. Installs what is missing (the experiment's packages: python3-openvdb,
# libopenvdb-dev for the header build-time measurement, python3-scipy,
# python3-nibabel), builds, then runs experiments/openvdb_eval.py with the
# arguments given here (--runs, --cases, --adaptivity, --decimate-errors, --out).
# Writes experiments/out/openvdb/result.json and table.md.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
ISOLOFT_EXTRA_PACKAGES="python3-openvdb libopenvdb-dev python3-scipy python3-nibabel mricron-data ${ISOLOFT_EXTRA_PACKAGES:-}" \
  "$ROOT/scripts/setup.sh"
exec /usr/bin/python3 "$ROOT/experiments/openvdb_eval.py" "$@"  # Debian's python, where the packages above live
