#!/usr/bin/env bash
# The tilted-tube kit (issue 23): every case of synth/tilted_tubes.h reconstructed with
# the per-column spline and the track z scheme (and its motion choices), ITK's
# MorphologicalContourInterpolator beside them, scored against the analytic
# truth; then the track scheme's cost against the per-column spline on the
# bundled frog example and the jawbone-scale real stack (experiments/
# real_stack.py). Writes experiments/out/tilted_tubes/ and paper/tilted_tubes.md.
#   scripts/tilted_tubes.sh             the kit, MCI and the timings (~10 min on 2 cores)
# env: RUNS (5 timed runs per scheme), THREADS (2), FROG_MHD (the shared
#      frog labels for the real stack; default ../shared/data/frog/frogtissue.mhd).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
PY=/usr/bin/python3  # Debian's, where the packages below live
"$ROOT/scripts/setup.sh" --full
NODE_DIR="$ROOT/experiments/peers_node"
if [[ ! -d "$NODE_DIR/node_modules/@itk-wasm/morphological-contour-interpolation" ]]; then
  (cd "$NODE_DIR" && npm ci --no-audit --no-fund --loglevel=error) || echo "tilted_tubes: npm ci failed; the mci peer is skipped"
fi
BIN="$ROOT/build/experiments/tilted_tubes"
OUT="$ROOT/experiments/out/tilted_tubes"
THREADS="${THREADS:-2}"
mkdir -p "$OUT"
"$BIN" --write-masks "$OUT/masks"
PEER=()
if "$PY" "$ROOT/experiments/tilted_tubes_mci.py" "$OUT/masks"; then PEER=(--peer "ITK MCI=$OUT/masks"); fi
"$BIN" --out "$OUT" --threads "$THREADS" "${PEER[@]}"
# Timings: reconstruct() alone (reading excluded), the two schemes alternating.
"$BIN" --time "$ROOT/data/frog" --kind labels --z-spacing 6 --runs "${RUNS:-5}" --threads "$THREADS" --name frog --out "$OUT"
FROG_MHD="${FROG_MHD:-$ROOT/../shared/data/frog/frogtissue.mhd}"
if [[ -f "$FROG_MHD" ]]; then
  "$PY" "$ROOT/experiments/real_stack.py" "$FROG_MHD" "$OUT/jawbone_scale.mha"
  "$BIN" --time "$OUT/jawbone_scale.mha" --kind labels --runs "${RUNS:-5}" --threads "$THREADS" --name jawbone_scale --out "$OUT"
fi
{
  echo "# The tilted-tube kit"
  echo
  echo "Made by \`scripts/tilted_tubes.sh\` (programs \`experiments/tilted_tubes.cpp\`, \`experiments/tilted_tubes_mci.py\`) on $(nproc) cores, isoloft $(git -C "$ROOT" describe --always --dirty)."
  echo "Cases: \`isoloft synth --list\` (synth/tilted_tubes.h). Volume ratio: inside samples 0.5 px apart (eval/volume.h);"
  echo "mean distance: two-sided, by the validation oracles (as paper/accuracy.md). ITK MCI: 3D Slicer's Fill between slices"
  echo "(experiments/anatomy_peers.py settings)."
  echo
  cat "$OUT/tilted_tubes.md"
  echo
  echo "Timings, reconstruct() wall seconds (median of ${RUNS:-5}, columns and track alternating, $THREADS threads):"
  echo
  echo "| input | columns | track | track / columns |"
  echo "|---|---|---|---|"
  for t in "$OUT"/timing_*.json; do
    "$PY" -c 'import json,sys; j=json.load(open(sys.argv[1])); n=sys.argv[1].split("timing_")[1][:-5]; print("| %s | %.2f | %.2f | %.2f |" % (n, j["columns"]["median_s"], j["track"]["median_s"], j["ratio_track_over_columns"]))' "$t"
  done
} > "$ROOT/paper/tilted_tubes.md"
echo "tilted_tubes: wrote paper/tilted_tubes.md"
