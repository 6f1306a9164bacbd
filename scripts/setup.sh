#!/usr/bin/env bash
# Installs what is missing (Debian 12, as root; idempotent) and builds isoloft
# in Release into build/.
#   setup.sh          the CLI and the Python module: the packages they need,
#                     targets `isoloft` and `_isoloft` (example.sh)
#   setup.sh --full   everything: tests, oracles, experiments, and the CLI
#                     linked with the one-definition-rule check (test.sh)
# Both put build/python on Debian's python3 path (a .pth file), so that
# `python3 -c "import isoloft"` works.
# A build/ already configured in full is never narrowed back to the CLI.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
FULL=0
if [[ "${1:-}" == "--full" ]]; then FULL=1; shift; fi
# What the CLI needs to build and run.
CLI_PACKAGES=(build-essential cmake git pkg-config time
  libeigen3-dev libtbb-dev libcli11-dev nlohmann-json3-dev libpng-dev zlib1g-dev
  libnifti2-dev libteem-dev libdcmtk-dev
  python3-dev pybind11-dev python3-numpy
  python3-venv python3-setuptools python3-wheel python3-build)
# Tests, oracles (CGAL, Ceres, OpenMesh), benchmarks, the AAL atlas the tests
# read, the Python packages of the pytest suite (images: nibabel; meshes: meshio,
# VTK; progress bars: tqdm; cohorts: dask, distributed; RT Structure Sets read back:
# pydicom, and dciodvfy from dicom3tools) and the real-anatomy
# metrics test, and clang-14 + its runtimes and linker (lld-14) for the sanitizer build and the
# libFuzzer targets (test.sh, fuzz.sh).
DEV_PACKAGES=(libcgal-dev libceres-dev libopenmesh-dev librapidcheck-dev libgtest-dev libgmock-dev libbenchmark-dev
  mricron-data python3-pytest python3-meshio python3-vtk9 python3-scipy python3-nibabel python3-tqdm
  python3-dask python3-distributed clang-14 libclang-rt-14-dev lld-14 python3-pydicom dicom3tools)
PACKAGES=("${CLI_PACKAGES[@]}")
((FULL)) && PACKAGES+=("${DEV_PACKAGES[@]}")
# Scripts that need more (reproduce.sh: plotting, DICOM) name it here.
read -r -a extra <<< "${ISOLOFT_EXTRA_PACKAGES:-}"
PACKAGES+=("${extra[@]}")

SUDO=""
[[ $(id -u) -ne 0 ]] && SUDO="sudo"
missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

JOBS="${ISOLOFT_JOBS:-$(nproc)}"
BUILD="$ROOT/build"
if ((!FULL)) && grep -qs "ISOLOFT_BUILD_TESTS:BOOL=ON" "$BUILD/CMakeCache.txt"; then FULL=1; fi
if ((FULL)); then
  OPTIONS=(-DISOLOFT_BUILD_TESTS=ON -DISOLOFT_BUILD_VALIDATION=ON -DISOLOFT_BUILD_EXPERIMENTS=ON -DISOLOFT_ODR_CHECK=ON)
  TARGET=all
else
  OPTIONS=(-DISOLOFT_BUILD_TESTS=OFF -DISOLOFT_BUILD_VALIDATION=OFF -DISOLOFT_BUILD_EXPERIMENTS=OFF)
  TARGET="isoloft _isoloft"
fi
cmake -S "$ROOT" -B "$BUILD" -DCMAKE_BUILD_TYPE=Release "${OPTIONS[@]}" "$@" > "$ROOT/build.log" 2>&1 || { cat "$ROOT/build.log"; exit 1; }
read -r -a targets <<< "$TARGET"
cmake --build "$BUILD" -j "$JOBS" --target "${targets[@]}" >> "$ROOT/build.log" 2>&1 || { tail -n 80 "$ROOT/build.log"; exit 1; }
echo "setup: built $BUILD ($TARGET; log: build.log)"

# `import isoloft` for Debian's python3: a .pth naming build/python in its
# site directory (/usr/local/lib/python3.X/dist-packages), rewritten each run.
SITE="$(/usr/bin/python3 -c 'import site; print(site.getsitepackages()[0])')"
$SUDO mkdir -p "$SITE"
echo "$BUILD/python" | $SUDO tee "$SITE/isoloft.pth" > /dev/null
/usr/bin/python3 -c "import isoloft" || { echo "setup: python3 cannot import isoloft (see $SITE/isoloft.pth)"; exit 1; }
echo "setup: python3 imports isoloft from $BUILD/python ($SITE/isoloft.pth)"
