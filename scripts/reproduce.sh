#!/usr/bin/env bash
# Reproduces the paper's tables and figures (Marker et al. 2006) on stand-in
# datasets and rebuilds paper/README.md from the experiments' outputs.
# Installs what is missing (plotting: python3-matplotlib; DICOM RT-STRUCT:
# python3-pydicom), builds, runs experiments/{reproduce_data,reproduce_tables,
# fig_*}.py into experiments/out/reproduce/, then scripts/make_paper.py.
# REPEATS=N sets the timing repetitions (default 3, median reported).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
ISOLOFT_EXTRA_PACKAGES="python3-numpy python3-matplotlib python3-pydicom ${ISOLOFT_EXTRA_PACKAGES:-}" "$ROOT/scripts/setup.sh" --full
PY=/usr/bin/python3  # Debian's, where the packages above live
OUT="$ROOT/experiments/out/reproduce"
export ISOLOFT_BUILD="$ROOT/build"
cd "$ROOT"
start=$SECONDS
"$PY" experiments/reproduce_data.py --out "$OUT/data"
"$PY" experiments/reproduce_tables.py --data "$OUT/data" --out "$OUT"
"$PY" experiments/table2_accuracy.py --data "$OUT/data" --out "$OUT"
"$PY" experiments/fig_fields.py --dataset "$OUT/data/J" --out "$OUT" --slice 45
"$PY" experiments/fig_spline.py --out "$OUT"
"$PY" experiments/fig_lip.py --out "$OUT"
"$PY" experiments/fig_renders.py --data "$OUT/data" --out "$OUT"
"$PY" scripts/make_paper.py --out "$OUT" --seconds $((SECONDS - start))
echo "reproduce: wrote paper/README.md in $((SECONDS - start)) s"
