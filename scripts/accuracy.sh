#!/usr/bin/env bash
# Accuracy benchmark (validation issue): every analytic shape at z ratios 4, 8
# and 16 as filled masks (KIND=contours: 1-pixel contour images), the default
# method, marker2006, levin and field3d (CONFIGS: any of experiments/accuracy.cpp's),
# against the analytic surface, with the input-slice Dice. Writes
# experiments/out/accuracy/ and copies the table to paper/accuracy.md and
# paper/accuracy.csv.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$ROOT/scripts/setup.sh" --full
OUT="$ROOT/experiments/out/accuracy"
"$ROOT/build/experiments/accuracy" --out "$OUT" --size "${SIZE:-128}" --ratios 4,8,16 --kind "${KIND:-masks}" \
  --configs "${CONFIGS:-isoloft,marker2006,levin,field3d}" "$@"
{
  echo "# Accuracy on analytic shapes"
  echo
  echo "Made by \`scripts/accuracy.sh\` (program \`experiments/accuracy.cpp\`) on $(nproc) cores, isoloft $(git -C "$ROOT" describe --always --dirty)."
  echo "Distances are measured by the validation oracles (\`validation/hausdorff.h\`): mesh to truth on sub-triangle samples,"
  echo "truth to mesh on projected samples of the analytic surface; the Hausdorff column is the lower end of the bounded interval."
  echo
  cat "$OUT/accuracy.md"
} > "$ROOT/paper/accuracy.md"
cp "$OUT/accuracy.csv" "$ROOT/paper/accuracy.csv"
echo "accuracy: wrote paper/accuracy.md"
