#!/usr/bin/env bash
# Benchmark, not a test (not in ctest): isoloft vs the VTK baseline
# (vtkVoxelContoursToSurfaceFilter + vtkQuadricDecimation) on the same
# synthetic jawbone-sized contour stack (branching cylinders, 500 x 500, z
# spacing 8). Installs what is missing (python3-numpy, python3-vtk9), builds,
# then runs experiments/vtk_side_by_side.py with the arguments given here
# (--size, --z-spacing, --runs, --threads, --decimate-error, --out, ...).
# Writes experiments/out/vtk_side_by_side/result.json and prints a table.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
ISOLOFT_EXTRA_PACKAGES="python3-numpy python3-vtk9 ${ISOLOFT_EXTRA_PACKAGES:-}" "$ROOT/scripts/setup.sh" --full
exec /usr/bin/python3 "$ROOT/experiments/vtk_side_by_side.py" "$@"  # Debian's python, where the packages above live
