#!/usr/bin/env bash
# Real-anatomy benchmark (issue 13): isoloft and its peers on frog organs and
# AAL structures, k = 2, 4, 8, staircase and smooth truths, one leaderboard.
# Installs what is missing (python3-vtk9, scipy, nibabel, pil, matplotlib;
# mricron-data for AAL; npm ci of the ITK-Wasm peer), builds the CLI, runs
# experiments/real_anatomy.py into experiments/out/real_anatomy/ and writes
# paper/real_anatomy.{md,csv} + paper/figures/real_anatomy.png.
#   scripts/real_anatomy.sh                 full run (fresh; ~45 min on 2 cores)
#   scripts/real_anatomy.sh --redo isoloft  rerun only isoloft's rows (after a change to it), keep the peers'
#   scripts/real_anatomy.sh --cases aal:41 --ks 4   a reduced pass (other flags: experiments/real_anatomy.py)
# THREADS=N (default 2) for isoloft and VTK.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
PY=/usr/bin/python3  # Debian's, where the packages below live
ISOLOFT_EXTRA_PACKAGES="python3-vtk9 python3-numpy python3-scipy python3-nibabel python3-pil python3-matplotlib mricron-data nodejs npm ${ISOLOFT_EXTRA_PACKAGES:-}"
missing=()
for p in $ISOLOFT_EXTRA_PACKAGES; do
  # node may come from elsewhere (e.g. NodeSource): only ask apt for it when there is none
  [[ $p == nodejs || $p == npm ]] && command -v "${p/nodejs/node}" >/dev/null && continue
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  SUDO=""; [[ $(id -u) -ne 0 ]] && SUDO="sudo"
  $SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
# The ITK-Wasm peer: pinned by package-lock.json; a failure only skips that peer.
NODE_DIR="$ROOT/experiments/peers_node"
if [[ ! -d "$NODE_DIR/node_modules/@itk-wasm/morphological-contour-interpolation" ]]; then
  (cd "$NODE_DIR" && npm ci --no-audit --no-fund --loglevel=error) || echo "real_anatomy: npm ci failed; the mci peer is skipped"
fi
BUILD="${ISOLOFT_BUILD:-$ROOT/build}"
# Only the CLI is needed: build that target alone (setup.sh on a fresh tree).
if [[ -f "$BUILD/CMakeCache.txt" ]]; then
  cmake --build "$BUILD" -j "${ISOLOFT_JOBS:-2}" --target isoloft > "$ROOT/build.log" 2>&1 || { tail -n 40 "$ROOT/build.log"; exit 1; }
else
  "$ROOT/scripts/setup.sh"
fi
export ISOLOFT_BUILD="$BUILD"
ARGS=("$@")
[[ " $* " == *" --redo "* || " $* " == *" --cases "* || " $* " == *" --systems "* ]] || ARGS=(--fresh "${ARGS[@]}")
start=$SECONDS
"$PY" "$ROOT/experiments/real_anatomy.py" --threads "${THREADS:-2}" "${ARGS[@]}"
"$PY" "$ROOT/experiments/real_anatomy_report.py" --seconds $((SECONDS - start))
echo "real_anatomy: $((SECONDS - start)) s; wrote paper/real_anatomy.md"
