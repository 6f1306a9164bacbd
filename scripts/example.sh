#!/usr/bin/env bash
# The main job on the bundled example: every 4th slice of the Whole Frog label
# map (data/frog, 34 slices of 500x470, 1 mm pixels, 6 mm apart), one closed
# mesh per organ plus a coloured combined mesh and a JSON report in out/.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$ROOT/scripts/setup.sh"
mkdir -p "$ROOT/out"
/usr/bin/time -v -o "$ROOT/out/frog_time.txt" \
  "$ROOT/build/isoloft" reconstruct "$ROOT/data/frog" --input labels --z-spacing 6 --pixel-size 1 \
  -o "$ROOT/out/frog.ply" --report "$ROOT/out/frog_report.json" "$@"
grep -E "Elapsed|Maximum resident" "$ROOT/out/frog_time.txt" | sed 's/^\s*/example: /'
echo "example: meshes and report in $ROOT/out/"
