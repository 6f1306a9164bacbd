#!/usr/bin/env bash
# Real-anatomy accuracy benchmark: every k-th slice (k = 2, 4, 8) of the Whole
# Frog label map (and of the AAL atlas, if mricron-data is installed) is
# reconstructed per label by marker2006 and levin and compared with the
# left-out original slices (Dice, symmetric boundary distance). Writes
# experiments/out/dense_truth/ and copies the table to paper/dense_truth.md and
# paper/dense_truth.csv.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$ROOT/scripts/setup.sh" --full
OUT="$ROOT/experiments/out/dense_truth"
FROG="$ROOT/../shared/data/frog/frogtissue.mhd"
AAL="${AAL:-/usr/share/mricron/templates/aal.nii.gz}"
if [[ ! -f "$AAL" ]] && ! dpkg-query -W -f='${Status}' mricron-data 2>/dev/null | grep -q "install ok installed"; then
  SUDO=""; [[ $(id -u) -ne 0 ]] && SUDO="sudo"
  $SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq mricron-data || true
fi
[[ -f "$AAL" ]] || echo "dense_truth: $AAL missing (apt-get install mricron-data); AAL is skipped"
"$ROOT/build/experiments/dense_truth" --out "$OUT" --frog "$FROG" --aal "$AAL" --ks 2,4,8 "$@"
{
  echo "# Accuracy on real segmentations with a dense truth"
  echo
  echo "Made by \`scripts/dense_truth.sh\` (program \`experiments/dense_truth.cpp\`) on $(nproc) cores, isoloft $(git -C "$ROOT" describe --always --dirty)."
  echo "Input: every k-th slice of a label map (Whole Frog: 1 x 1 x 1.5 mm; AAL: 1 mm iso, axial); the interpolated field is sampled"
  echo "on the left-out original slices and thresholded at 0. Dice is pooled over those slices; the boundary distance pools both"
  echo "masks' boundary pixels (\`mask_boundary\`), each to the nearest boundary pixel of the other (exact EDT), over slices where"
  echo "both masks are non-empty. The truth itself is jagged in z by about a voxel (per-slice segmentation)."
  echo
  cat "$OUT/dense_truth.md"
} > "$ROOT/paper/dense_truth.md"
cp "$OUT/dense_truth.csv" "$ROOT/paper/dense_truth.csv"
echo "dense_truth: wrote paper/dense_truth.md"
