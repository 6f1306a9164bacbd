#!/usr/bin/env bash
# Installs what is missing (Debian 12, as root; idempotent) and builds isoloft
# in Release into build/. Used by example.sh and test.sh.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
PACKAGES=(build-essential cmake git pkg-config time
  libcgal-dev libeigen3-dev libceres-dev libopenmesh-dev librapidcheck-dev libgtest-dev libgmock-dev
  libtbb-dev libcli11-dev nlohmann-json3-dev libpng-dev zlib1g-dev libbenchmark-dev)
# Scripts that need more (reproduce.sh: plotting, DICOM) name it here.
read -r -a extra <<< "${ISOLOFT_EXTRA_PACKAGES:-}"
PACKAGES+=("${extra[@]}")

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}"
  SUDO=""
  [[ $(id -u) -ne 0 ]] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

JOBS="${ISOLOFT_JOBS:-$(nproc)}"
cmake -S "$ROOT" -B "$ROOT/build" -DCMAKE_BUILD_TYPE=Release "$@" > "$ROOT/build.log" 2>&1 || { cat "$ROOT/build.log"; exit 1; }
cmake --build "$ROOT/build" -j "$JOBS" >> "$ROOT/build.log" 2>&1 || { tail -n 80 "$ROOT/build.log"; exit 1; }
echo "setup: built $ROOT/build (log: build.log)"
